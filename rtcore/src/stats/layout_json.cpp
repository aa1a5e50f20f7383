// layout_json.cpp -- offsetof() of every field of Header, TimingRecord and Histogram.
#include "stats/layout_json.hpp"

#include "stats/stats_block.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>

namespace irp::stats {
namespace {

using json = nlohmann::ordered_json;

json field(std::size_t offset, const char *type) { return {{"offset", offset}, {"type", type}}; }

} // namespace

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Winvalid-offsetof"  // standard-layout, checked by static_assert
json layoutJson() {
    json header = {
        {"magic", field(offsetof(Header, magic), "u64")},
        {"version", field(offsetof(Header, version), "u32")},
        {"header_size", field(offsetof(Header, header_size), "u32")},
        {"record_size", field(offsetof(Header, record_size), "u32")},
        {"record_count", field(offsetof(Header, record_count), "u32")},
        {"pid", field(offsetof(Header, pid), "i64")},
        {"basic_ns", field(offsetof(Header, basic_ns), "i64")},
        {"macro_ns", field(offsetof(Header, macro_ns), "i64")},
        {"realtime", field(offsetof(Header, realtime), "u32")},
        {"running", field(offsetof(Header, running), "u32")},
        {"started_ns", field(offsetof(Header, started_ns), "i64")},
        {"finished_ns", field(offsetof(Header, finished_ns), "i64")},
        {"cycles", field(offsetof(Header, cycles), "u64")},
        {"set_path", field(offsetof(Header, set_path), "char[512]")},
    };
    json record = {
        {"name", field(offsetof(TimingRecord, name), "char[64]")},
        {"executor", field(offsetof(TimingRecord, executor), "char[64]")},
        {"kind", field(offsetof(TimingRecord, kind), "u32")},
        {"state", field(offsetof(TimingRecord, state), "u32")},
        {"priority", field(offsetof(TimingRecord, priority), "i32")},
        {"period_ns", field(offsetof(TimingRecord, period_ns), "i64")},
        {"budget_ns", field(offsetof(TimingRecord, budget_ns), "i64")},
        {"runs", field(offsetof(TimingRecord, runs), "u64")},
        {"overruns", field(offsetof(TimingRecord, overruns), "u64")},
        {"missed", field(offsetof(TimingRecord, missed), "u64")},
        {"skipped", field(offsetof(TimingRecord, skipped), "u64")},
        {"errors", field(offsetof(TimingRecord, errors), "u64")},
        {"caught_up", field(offsetof(TimingRecord, caught_up), "u64")},
        {"jitter.negative", field(offsetof(TimingRecord, jitter) + offsetof(SignedHistogram, negative), "histogram")},
        {"jitter.positive", field(offsetof(TimingRecord, jitter) + offsetof(SignedHistogram, positive), "histogram")},
        {"latency", field(offsetof(TimingRecord, latency), "histogram")},
        {"exec", field(offsetof(TimingRecord, exec), "histogram")},
    };
    json histogram = {
        {"size", sizeof(Histogram)},
        {"count", field(offsetof(Histogram, count), "u64")},
        {"sum", field(offsetof(Histogram, sum), "u64")},
        {"min", field(offsetof(Histogram, min), "u64")},
        {"max", field(offsetof(Histogram, max), "u64")},
        {"buckets", field(offsetof(Histogram, buckets), "u64[]")},
        {"bucket_count", kBuckets},
        {"sub_bucket_bits", kSubBucketBits},
        {"max_exponent", kMaxExponent},
    };
    return {{"magic", kMagic},
            {"version", kVersion},
            {"byte_order", "little"},
            {"header_size", sizeof(Header)},
            {"record_size", sizeof(TimingRecord)},
            {"record_kinds", {{"dispatcher", 0}, {"module", 1}}},
            {"module_states", {"loaded", "running", "disabled", "skipped", "stopped", "exited"}},
            {"header", header},
            {"record", record},
            {"histogram", histogram}};
}
#pragma GCC diagnostic pop

} // namespace irp::stats
