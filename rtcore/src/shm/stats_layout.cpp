// stats_layout.cpp -- the stats block ("/indurop.<instance>.stats", stats/stats_block.hpp) described
// field by field for --print-shm-layout.
#include "shm/describe.hpp"

#include "stats/stats_block.hpp"

namespace irp::shm {

IRP_SHM_TYPE_NAME(stats::Header, "stats_header");
IRP_SHM_TYPE_NAME(stats::TimingRecord, "timing_record");
IRP_SHM_TYPE_NAME(stats::SignedHistogram, "signed_histogram");
IRP_SHM_TYPE_NAME(stats::Histogram, "histogram");

namespace {

// The records hold atomics: standard layout all the same (stats_block.hpp asserts it), so
// offsetof is well defined; GCC warns about offsetof on any class with atomics.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Winvalid-offsetof"

using H = stats::Header;
constexpr Field kHeader[] = {
    IRP_SHM_FIELD(H, magic, "the bytes IRPSTAT1"),
    IRP_SHM_FIELD(H, version, "the segment's format version"),
    IRP_SHM_FIELD(H, header_size, "bytes of this header; the records follow it"),
    IRP_SHM_FIELD(H, record_size, "bytes of one timing_record"),
    IRP_SHM_FIELD(H, record_count,
                  "records: dispatchers first (main, then each executor), then modules and unused ones"),
    IRP_SHM_FIELD(H, pid, "the irpd that owns the segment"),
    IRP_SHM_FIELD(H, basic_ns, "the basic period"),
    IRP_SHM_FIELD(H, macro_ns, "the macro period"),
    IRP_SHM_FIELD(H, realtime, "1 = every dispatcher thread got SCHED_FIFO"),
    IRP_SHM_FIELD(H, running, "1 while the dispatchers run"),
    IRP_SHM_FIELD(H, started_ns, "CLOCK_MONOTONIC time of slot 0 (T0 of the main dispatcher)"),
    IRP_SHM_FIELD(H, finished_ns, "when the main dispatcher's last slot ended (0 while running)"),
    IRP_SHM_FIELD(H, cycles, "basic periods completed by the main dispatcher"),
    IRP_SHM_FIELD(H, set_path, "module.xml of the running set, NUL-terminated"),
};
IRP_SHM_DESCRIBES(stats::Header, kHeader);

using R = stats::TimingRecord;
constexpr Field kRecord[] = {
    IRP_SHM_FIELD(R, name, "the module's or the dispatcher's name, NUL-terminated"),
    IRP_SHM_FIELD(R, executor, "the dispatcher thread it runs on (\"main\", ...), NUL-terminated"),
    IRP_SHM_FIELD(R, kind, "record_kind"),
    IRP_SHM_FIELD(R, state, "module_state (modules), or 1 while the dispatcher runs"),
    IRP_SHM_FIELD(R, priority, "the module's priority (lowest value first)"),
    IRP_SHM_FIELD(R, reserved0, "zero"),
    IRP_SHM_FIELD(R, period_ns, "the module's period, or the basic period for a dispatcher"),
    IRP_SHM_FIELD(R, budget_ns, "execution budget, 0 = none"),
    IRP_SHM_FIELD(R, runs, "run() calls (modules) / slots executed (dispatchers)"),
    IRP_SHM_FIELD(R, overruns, "modules: exec above budget; dispatchers: slot work above the basic period"),
    IRP_SHM_FIELD(R, missed, "started a whole period (the module's, or the basic one) or more after it was due"),
    IRP_SHM_FIELD(R, skipped, "runs or slots dropped by the overrun policy"),
    IRP_SHM_FIELD(R, errors, "exceptions thrown out of run()"),
    IRP_SHM_FIELD(R, caught_up, "dispatchers: slots started at once, without sleeping, after a late slot"),
    IRP_SHM_FIELD(R, stats_dropped,
                  "modules: runs whose figures were lost (the sample ring was full): in neither runs nor the "
                  "histograms; dispatchers: the sum over their modules"),
    IRP_SHM_FIELD(R, jitter, "Eq. (1): J_n = T0 + n x period - T_n, in ns"),
    IRP_SHM_FIELD(R, latency, "start (wake-up for a dispatcher) minus its planned time, in ns"),
    IRP_SHM_FIELD(R, exec, "execution time of run() / of the slot's whole work, in ns"),
};
IRP_SHM_DESCRIBES(stats::TimingRecord, kRecord);

using SH = stats::SignedHistogram;
constexpr Field kSigned[] = {
    IRP_SHM_FIELD(SH, negative, "magnitudes of the negative values: -1 counts as 1"),
    IRP_SHM_FIELD(SH, positive, "zero and the positive values"),
};
IRP_SHM_DESCRIBES(stats::SignedHistogram, kSigned);

using Hi = stats::Histogram;
constexpr Field kHistogram[] = {
    IRP_SHM_FIELD(Hi, count, "values recorded; stored last, so a reader may see it one behind the buckets"),
    IRP_SHM_FIELD(Hi, sum, "their sum"),
    IRP_SHM_FIELD(Hi, min, "the smallest, 18446744073709551615 while empty"),
    IRP_SHM_FIELD(Hi, max, "the largest, exact"),
    IRP_SHM_FIELD(Hi, buckets,
                  "log-linear: values below 2^sub_bucket_bits exactly, then 2^sub_bucket_bits "
                  "buckets per power of two up to 2^max_exponent; larger values in the last bucket"),
};
IRP_SHM_DESCRIBES(stats::Histogram, kHistogram);

#pragma GCC diagnostic pop

constexpr Struct kStructs[] = {
    describe<H>("At offset 0", kHeader),
    describe<R>("From header_size on: record_count of them, record_size bytes apart; each field has a single "
                "writer: its dispatcher thread, except a module's runs and histograms, which irpd's stats thread "
                "folds from the dispatcher's samples within a millisecond",
                kRecord),
    describe<SH>("A histogram of signed values", kSigned),
    describe<Hi>("A log-linear histogram of non-negative values, in ns", kHistogram),
};

constexpr Constant kConstants[] = {
    {"bucket_count", stats::kBuckets, "buckets of a histogram"},
    {"sub_bucket_bits", stats::kSubBucketBits, "log2 of the buckets per power of two"},
    {"max_exponent", stats::kMaxExponent, "values of 2^max_exponent ns and more share the last bucket"},
};

constexpr Constant kKinds[] = {
    {"dispatcher", static_cast<uint32_t>(stats::RecordKind::Dispatcher), "a dispatcher (executor) thread"},
    {"module", static_cast<uint32_t>(stats::RecordKind::Module), "a module"},
    {"unused", static_cast<uint32_t>(stats::RecordKind::Unused), "a free record for a hot reload; readers skip it"},
};
constexpr Constant kStates[] = {
    {"loaded", static_cast<uint32_t>(stats::ModuleState::Loaded), "loaded and initialized, not dispatched yet"},
    {"running", static_cast<uint32_t>(stats::ModuleState::Running), "called every period"},
    {"disabled", static_cast<uint32_t>(stats::ModuleState::Disabled), "taken out of the slot table after a fault"},
    {"skipped", static_cast<uint32_t>(stats::ModuleState::Skipped), "a kind of module this irpd cannot run"},
    {"stopped", static_cast<uint32_t>(stats::ModuleState::Stopped), "stopped"},
    {"exited", static_cast<uint32_t>(stats::ModuleState::Exited), "a process module that is not running"},
};

constexpr Enum kEnums[] = {
    {"record_kind", "timing_record.kind", kKinds},
    {"module_state", "timing_record.state of a module", kStates},
};

}  // namespace

const Segment &statsSegment() {
    static constexpr Segment segment{
        "stats",
        "/indurop.<instance>.stats",
        "Timing figures of the running set: [header][timing_record x record_count], every struct 64-byte aligned. "
        "The RT threads and irpd's stats thread write them with plain stores; readers never make them wait "
        "(docs/scheduler.md).",
        stats::kMagic,
        stats::kVersion,
        TypeName<H>::value,
        kStructs,
        kConstants,
        kEnums};
    return segment;
}

}  // namespace irp::shm
