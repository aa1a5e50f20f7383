// summary.cpp -- reads histograms into figures (min, max, mean, p50, p99, p99.9).
#include "stats/summary.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace irp::stats {
namespace {

constexpr auto relaxed = std::memory_order_relaxed;

double mid(std::size_t i) { return static_cast<double>(bucketLow(i)) + static_cast<double>(bucketWidth(i) - 1) / 2.0; }

uint64_t rankOf(uint64_t count, double q) {
    auto r = static_cast<uint64_t>(std::ceil(q * static_cast<double>(count)));
    return std::clamp<uint64_t>(r, 1, count);
}

uint64_t bucketSum(const Histogram &h) {
    uint64_t n = 0;
    for (const Counter &b : h.buckets) n += b.load(relaxed);
    return n;
}

}  // namespace

double quantile(const Histogram &h, double q) {
    uint64_t total = bucketSum(h);  // the buckets themselves, so a live reader stays consistent
    if (total == 0) return 0;
    uint64_t rank = rankOf(total, q), seen = 0;
    double lo = static_cast<double>(h.min.load(relaxed)), hi = static_cast<double>(h.max.load(relaxed));
    for (std::size_t i = 0; i < kBuckets; ++i) {
        seen += h.buckets[i].load(relaxed);
        if (seen >= rank) return std::clamp(mid(i), std::min(lo, hi), hi);
    }
    return hi;
}

double quantile(const SignedHistogram &h, double q) {
    uint64_t neg = bucketSum(h.negative), pos = bucketSum(h.positive);
    if (neg + pos == 0) return 0;
    uint64_t rank = rankOf(neg + pos, q);
    if (rank <= neg) {
        // The negative half, most negative first: walk its magnitudes from the top.
        uint64_t seen = 0;
        double lo = static_cast<double>(h.negative.min.load(relaxed)),
               hi = static_cast<double>(h.negative.max.load(relaxed));
        for (std::size_t i = kBuckets; i-- > 0;) {
            seen += h.negative.buckets[i].load(relaxed);
            if (seen >= rank) return -std::clamp(mid(i), std::min(lo, hi), hi);
        }
        return -lo;
    }
    Histogram const &p = h.positive;
    uint64_t seen = neg;
    double lo = static_cast<double>(p.min.load(relaxed)), hi = static_cast<double>(p.max.load(relaxed));
    for (std::size_t i = 0; i < kBuckets; ++i) {
        seen += p.buckets[i].load(relaxed);
        if (seen >= rank) return std::clamp(mid(i), std::min(lo, hi), hi);
    }
    return hi;
}

Summary summarize(const Histogram &h) {
    Summary s;
    s.count = h.count.load(relaxed);
    if (s.count == 0) return s;
    s.min = static_cast<double>(h.min.load(relaxed));
    s.max = static_cast<double>(h.max.load(relaxed));
    s.mean = static_cast<double>(h.sum.load(relaxed)) / static_cast<double>(s.count);
    s.p50 = quantile(h, 0.50);
    s.p99 = quantile(h, 0.99);
    s.p999 = quantile(h, 0.999);
    return s;
}

Summary summarize(const SignedHistogram &h) {
    Summary s;
    uint64_t neg = h.negative.count.load(relaxed), pos = h.positive.count.load(relaxed);
    s.count = neg + pos;
    if (s.count == 0) return s;
    s.min =
        neg ? -static_cast<double>(h.negative.max.load(relaxed)) : static_cast<double>(h.positive.min.load(relaxed));
    s.max =
        pos ? static_cast<double>(h.positive.max.load(relaxed)) : -static_cast<double>(h.negative.min.load(relaxed));
    s.mean = (static_cast<double>(h.positive.sum.load(relaxed)) - static_cast<double>(h.negative.sum.load(relaxed))) /
             static_cast<double>(s.count);
    s.p50 = quantile(h, 0.50);
    s.p99 = quantile(h, 0.99);
    s.p999 = quantile(h, 0.999);
    return s;
}

nlohmann::ordered_json toJson(const Summary &s) {
    return {{"count", s.count}, {"min", s.min}, {"max", s.max},  {"mean", s.mean},
            {"p50", s.p50},     {"p99", s.p99}, {"p999", s.p999}};
}

const char *toString(ModuleState state) {
    switch (state) {
    case ModuleState::Loaded: return "loaded";
    case ModuleState::Running: return "running";
    case ModuleState::Disabled: return "disabled";
    case ModuleState::Skipped: return "skipped";
    case ModuleState::Stopped: return "stopped";
    case ModuleState::Exited: return "exited";
    }
    return "unknown";
}

nlohmann::ordered_json toJson(const TimingRecord &r) {
    nlohmann::ordered_json j = {{"name", r.name},
                                {"executor", r.executor},
                                {"kind", r.kind == RecordKind::Dispatcher ? "dispatcher" : "module"},
                                {"period_ns", r.period_ns},
                                {"runs", r.runs.load(relaxed)},
                                {"jitter_ns", toJson(summarize(r.jitter))},
                                {"latency_ns", toJson(summarize(r.latency))},
                                {"exec_ns", toJson(summarize(r.exec))},
                                {"overruns", r.overruns.load(relaxed)},
                                {"missed", r.missed.load(relaxed)},
                                {"skipped", r.skipped.load(relaxed)},
                                {"errors", r.errors.load(relaxed)},
                                {"stats_dropped", r.stats_dropped.load(relaxed)}};
    if (r.kind == RecordKind::Dispatcher) j["caught_up"] = r.caught_up.load(relaxed);
    if (r.kind == RecordKind::Module) {
        j["state"] = toString(static_cast<ModuleState>(r.state.load(relaxed)));
        j["priority"] = r.priority;
        j["budget_ns"] = r.budget_ns;
    }
    return j;
}

namespace {

struct Listed {
    nlohmann::ordered_json buckets = nlohmann::ordered_json::array();
    uint64_t count = 0;
    int64_t lowest = 0, highest = 0;  // the smallest and largest value the listed buckets can hold
};

// Appends bucket i of a histogram of magnitudes, as values of the given sign.
void list(Listed &out, std::size_t i, uint64_t n, bool negative) {
    const auto low = static_cast<int64_t>(bucketLow(i)), width = static_cast<int64_t>(bucketWidth(i));
    // Magnitudes [low, low + width) are the values [-(low + width - 1), -low].
    const int64_t from = negative ? -(low + width - 1) : low;
    if (out.count == 0) out.lowest = from;
    out.highest = from + width - 1;
    out.buckets.push_back({from, width, n});
    out.count += n;
}

// A stored value as int64 (UINT64_MAX, an empty histogram's min, becomes INT64_MAX).
int64_t signedOf(uint64_t v) {
    return v > static_cast<uint64_t>(std::numeric_limits<int64_t>::max()) ? std::numeric_limits<int64_t>::max()
                                                                          : static_cast<int64_t>(v);
}

}  // namespace

// min and max are stored after a sample's bucket, so a live reader may see them lag the buckets by
// one sample: a min above every listed bucket or a max below them is replaced by the buckets' bound.
nlohmann::ordered_json histogramJson(const Histogram &h) {
    Listed l;
    for (std::size_t i = 0; i < kBuckets; ++i)
        if (const uint64_t n = h.buckets[i].load(relaxed)) list(l, i, n, false);
    if (l.count == 0) return {{"count", 0}, {"min", 0}, {"max", 0}, {"buckets", std::move(l.buckets)}};
    const uint64_t min = h.min.load(relaxed), max = h.max.load(relaxed);
    return {{"count", l.count},
            {"min", min > static_cast<uint64_t>(l.highest) ? l.lowest : static_cast<int64_t>(min)},
            {"max", max < static_cast<uint64_t>(l.lowest) ? l.highest : static_cast<int64_t>(max)},
            {"buckets", std::move(l.buckets)}};
}

nlohmann::ordered_json histogramJson(const SignedHistogram &h) {
    Listed l;
    for (std::size_t i = kBuckets; i-- > 0;)  // the most negative first
        if (const uint64_t n = h.negative.buckets[i].load(relaxed)) list(l, i, n, true);
    const uint64_t negatives = l.count;
    for (std::size_t i = 0; i < kBuckets; ++i)
        if (const uint64_t n = h.positive.buckets[i].load(relaxed)) list(l, i, n, false);
    const uint64_t positives = l.count - negatives;
    if (l.count == 0) return {{"count", 0}, {"min", 0}, {"max", 0}, {"buckets", std::move(l.buckets)}};
    int64_t min = negatives ? -signedOf(h.negative.max.load(relaxed)) : signedOf(h.positive.min.load(relaxed));
    int64_t max = positives ? signedOf(h.positive.max.load(relaxed)) : -signedOf(h.negative.min.load(relaxed));
    if (min > l.highest) min = l.lowest;
    if (max < l.lowest) max = l.highest;
    return {{"count", l.count}, {"min", min}, {"max", max}, {"buckets", std::move(l.buckets)}};
}

nlohmann::ordered_json histogramsJson(const TimingRecord &r) {
    return {{"name", r.name},
            {"kind", r.kind == RecordKind::Dispatcher ? "dispatcher" : "module"},
            {"executor", r.executor},
            {"runs", r.runs.load(relaxed)},
            {"overruns", r.overruns.load(relaxed)},
            {"missed", r.missed.load(relaxed)},
            {"skipped", r.skipped.load(relaxed)},
            {"errors", r.errors.load(relaxed)},
            {"stats_dropped", r.stats_dropped.load(relaxed)},
            {"jitter_ns", histogramJson(r.jitter)},
            {"latency_ns", histogramJson(r.latency)},
            {"exec_ns", histogramJson(r.exec)}};
}

uint64_t statsDropped(const TimingRecord *records, const std::vector<std::size_t> &executors) {
    uint64_t sum = 0;
    for (std::size_t i : executors) sum += records[i].stats_dropped.load(relaxed);
    return sum;
}

}  // namespace irp::stats
