// summary.hpp -- percentiles and JSON from the histograms of a stats block, and the histograms
// themselves as JSON (their non-empty buckets).
#pragma once

#include "stats/stats_block.hpp"

#include <nlohmann/json_fwd.hpp>

#include <cstddef>
#include <vector>

namespace irp::stats {

struct Summary {
    uint64_t count = 0;
    double min = 0, max = 0, mean = 0, p50 = 0, p99 = 0, p999 = 0;
};

Summary summarize(const Histogram &h);
Summary summarize(const SignedHistogram &h);

// Value at quantile q (0..1): the middle of the bucket holding it, clamped to [min, max].
double quantile(const Histogram &h, double q);
double quantile(const SignedHistogram &h, double q);

// {min, max, mean, p50, p99, p999, count}
nlohmann::ordered_json toJson(const Summary &s);

// {name, executor, kind, state, period_ns, runs, jitter_ns, latency_ns, exec_ns, overruns, missed, skipped, errors,
// stats_dropped}
nlohmann::ordered_json toJson(const TimingRecord &r);

const char *toString(ModuleState state);

// {count, min, max, buckets: [[low, width, count], ...]}: the non-empty buckets in ascending order,
// each holding the values in [low, low + width).  A signed histogram lists its negative values
// first (low < 0).  count is the sum of the buckets listed (one consistent read of a live record).
nlohmann::ordered_json histogramJson(const Histogram &h);
nlohmann::ordered_json histogramJson(const SignedHistogram &h);

// {name, kind, executor, runs, overruns, missed, skipped, errors, stats_dropped, jitter_ns, latency_ns, exec_ns}
// with the three histograms as histogramJson.
nlohmann::ordered_json histogramsJson(const TimingRecord &r);

// Runs whose figures a full sample ring lost, over the executors whose records are listed (each
// dispatcher's record holds the sum over its modules).
uint64_t statsDropped(const TimingRecord *records, const std::vector<std::size_t> &executors);

}  // namespace irp::stats
