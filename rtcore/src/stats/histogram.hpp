// histogram.hpp -- log-linear histograms of nanosecond values that the RT thread updates with
// plain stores (no syscall, lock, allocation or read-modify-write bus lock) and that other
// processes read live from shared memory.
//
// Buckets: values 0..31 exactly, then 32 sub-buckets per power of two up to 2^36 ns (68 s), so a
// bucket is at most 1/32 (3.1 %) of its value wide; larger values land in the last bucket and the
// exact maximum is kept beside.  Each histogram has a single writer: the dispatcher thread that
// owns the record, or for a module's histograms irpd's stats thread that folds its dispatcher's
// samples (stats/sample_ring.hpp).  Readers may see a count one sample ahead of the buckets;
// nothing else tears.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <limits>

namespace irp::stats {

static_assert(std::atomic<uint64_t>::is_always_lock_free, "shared-memory counters must be address-free");
static_assert(std::atomic<int64_t>::is_always_lock_free, "shared-memory counters must be address-free");

using Counter = std::atomic<uint64_t>;

// Single-writer increment: a load and a store, no locked instruction.
inline void bump(Counter &c, uint64_t by = 1) noexcept {
    c.store(c.load(std::memory_order_relaxed) + by, std::memory_order_relaxed);
}

inline constexpr int kSubBucketBits = 5;
inline constexpr uint64_t kSubBuckets = 1u << kSubBucketBits;
inline constexpr int kMaxExponent = 36;
inline constexpr std::size_t kBuckets = kSubBuckets + (kMaxExponent - kSubBucketBits + 1) * kSubBuckets;

constexpr std::size_t bucketOf(uint64_t v) noexcept {
    if (v < kSubBuckets) return static_cast<std::size_t>(v);
    int e = 63 - __builtin_clzll(v);
    if (e > kMaxExponent) return kBuckets - 1;
    return static_cast<std::size_t>(kSubBuckets + static_cast<uint64_t>(e - kSubBucketBits) * kSubBuckets +
                                    ((v >> (e - kSubBucketBits)) & (kSubBuckets - 1)));
}

// Smallest value of bucket i, and its width.
constexpr uint64_t bucketLow(std::size_t i) noexcept {
    if (i < kSubBuckets) return i;
    uint64_t k = (i - kSubBuckets) / kSubBuckets;
    uint64_t sub = (i - kSubBuckets) % kSubBuckets;
    int e = static_cast<int>(k) + kSubBucketBits;
    return (uint64_t{1} << e) | (sub << (e - kSubBucketBits));
}
constexpr uint64_t bucketWidth(std::size_t i) noexcept {
    if (i < kSubBuckets) return 1;
    int e = static_cast<int>((i - kSubBuckets) / kSubBuckets) + kSubBucketBits;
    return uint64_t{1} << (e - kSubBucketBits);
}

static_assert(bucketOf(bucketLow(kBuckets - 1)) == kBuckets - 1, "bucket bounds must round-trip");
static_assert(bucketOf(100'000) < kBuckets && bucketLow(bucketOf(100'000)) <= 100'000, "100 us must fit");

// A histogram of non-negative values.
struct Histogram {
    Counter count;
    Counter sum;
    Counter min;  // UINT64_MAX while empty
    Counter max;
    Counter buckets[kBuckets];

    void reset() noexcept {
        count.store(0, std::memory_order_relaxed);
        sum.store(0, std::memory_order_relaxed);
        min.store(std::numeric_limits<uint64_t>::max(), std::memory_order_relaxed);
        max.store(0, std::memory_order_relaxed);
        for (Counter &b : buckets) b.store(0, std::memory_order_relaxed);
    }

    void record(uint64_t v) noexcept {
        bump(buckets[bucketOf(v)]);
        bump(sum, v);
        if (v < min.load(std::memory_order_relaxed)) min.store(v, std::memory_order_relaxed);
        if (v > max.load(std::memory_order_relaxed)) max.store(v, std::memory_order_relaxed);
        bump(count);  // last: a reader that sees the count sees the sample's bucket
    }
};

// A histogram of signed values (jitter per Eq. (1) can be early or late): magnitudes of the
// negative values in one half, zero and positive values in the other.
struct SignedHistogram {
    Histogram negative;
    Histogram positive;

    void reset() noexcept {
        negative.reset();
        positive.reset();
    }
    void record(int64_t v) noexcept {
        if (v < 0)
            negative.record(static_cast<uint64_t>(-(v + 1)) + 1);
        else
            positive.record(static_cast<uint64_t>(v));
    }
};

}  // namespace irp::stats
