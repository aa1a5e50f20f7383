// bench_hist.hpp -- the benchmark programs' latency histogram: irpd's log-linear buckets
// (rtcore/src/stats/histogram.hpp: 0..31 ns exactly, then 32 buckets per power of two up to 2^36 ns),
// so that run_bench.py summarizes and merges them with the code it uses for irpd's own, and a
// text form that survives irpd's "[name] " output forwarding (lines of at most ~1 KiB).
//
//   @hist <label> count=N sum=S min=M max=X sub_bucket_bits=5 max_exponent=36 bucket_count=1056
//   @buckets <label> index:count index:count ...      (non-empty buckets, 48 per line)
//   @info <label> key=value ...                       (counters a program adds)
//   @end <label>
#pragma once

#include "stats/histogram.hpp"

#include <sys/mman.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <ctime>

namespace bench {

// irpd's own bucket arithmetic, so both sides always agree.
using irp::stats::bucketOf;
using irp::stats::kBuckets;
using irp::stats::kMaxExponent;
using irp::stats::kSubBucketBits;

inline int64_t nowNs() noexcept {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1'000'000'000LL + ts.tv_nsec;
}

// Single writer, no allocation, no syscall: record() is safe in an RT loop.
struct Histogram {
    uint64_t count = 0, sum = 0, min = UINT64_MAX, max = 0;
    uint64_t buckets[kBuckets] = {};

    // Negative values (a clock read before the due time cannot happen, but a skewed source can) count as 0.
    void record(int64_t signed_value) noexcept {
        const uint64_t v = signed_value > 0 ? static_cast<uint64_t>(signed_value) : 0;
        ++buckets[bucketOf(v)];
        sum += v;
        if (v < min) min = v;
        if (v > max) max = v;
        ++count;
    }

    // Prints the text form on `out`, flushed line by line (a pipe is block-buffered).
    void print(std::FILE *out, const char *label) const {
        std::fprintf(out,
                     "@hist %s count=%llu sum=%llu min=%llu max=%llu sub_bucket_bits=%d max_exponent=%d "
                     "bucket_count=%zu\n",
                     label, static_cast<unsigned long long>(count), static_cast<unsigned long long>(sum),
                     static_cast<unsigned long long>(count ? min : 0), static_cast<unsigned long long>(max),
                     kSubBucketBits, kMaxExponent, kBuckets);
        std::fflush(out);
        int on_line = 0;
        for (std::size_t i = 0; i < kBuckets; ++i) {
            if (!buckets[i]) continue;
            if (on_line == 0) std::fprintf(out, "@buckets %s", label);
            std::fprintf(out, " %zu:%llu", i, static_cast<unsigned long long>(buckets[i]));
            if (++on_line == 48) {
                std::fputc('\n', out);
                std::fflush(out);
                on_line = 0;
            }
        }
        if (on_line) std::fputc('\n', out);
        std::fprintf(out, "@end %s\n", label);
        std::fflush(out);
    }
};

// Locks the process's memory so that the measurement never waits for a page fault (irpd itself
// runs mlockall'd; a process module is told to do the same, docs/process-modules.md).
inline bool lockMemory() noexcept { return mlockall(MCL_CURRENT | MCL_FUTURE) == 0; }

}  // namespace bench
