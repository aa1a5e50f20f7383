// sample_ring.hpp -- each module run's raw figures, handed from the RT thread that measured them to
// the thread that folds them into the shared-memory stats block (dispatch::Executor::foldStats).
//
// Why: a run's histogram and counter updates touch about seven cache lines on four pages of its
// module's 34 KiB record, which other work evicts between two slots; the RT thread paid those
// misses (docs/benchmark.md).  It now writes one 32-byte sample into this contiguous ring instead,
// and a non-RT thread applies it to the record within a fold interval.  Single producer (the
// executor's thread), single consumer at a time (the caller of fold() holds the executor's lock).
// A full ring never blocks the producer: push() returns false and the caller counts the loss.
#pragma once

#include "stats/stats_block.hpp"

#include <atomic>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <memory>

namespace irp::stats {

// One run's figures for one record: which of them it carries is in the record word's low bits
// (records are 64-byte aligned, so the pointer's low six bits are free).
struct RunSample {
    enum What : uintptr_t { kJitter = 1, kLatency = 2, kExec = 4, kRun = 8, kWhatMask = 63 };
    uintptr_t record = 0;  // TimingRecord * | What
    int64_t jitter = 0;    // Eq. (1)
    uint64_t latency = 0;  // start - due
    uint64_t exec = 0;     // execution time
};
static_assert(alignof(TimingRecord) > RunSample::kWhatMask, "the record word keeps `what` in its low bits");
static_assert(sizeof(RunSample) == 32, "two samples a cache line");

// Adds one sample's figures to its record: what the RT thread did per run before the ring.
inline void apply(const RunSample &s) noexcept {
    auto &r = *reinterpret_cast<TimingRecord *>(s.record & ~uintptr_t{RunSample::kWhatMask});
    const uintptr_t what = s.record & RunSample::kWhatMask;
    if (what & RunSample::kJitter) r.jitter.record(s.jitter);
    if (what & RunSample::kLatency) r.latency.record(s.latency);
    if (what & RunSample::kExec) r.exec.record(s.exec);
    if (what & RunSample::kRun) bump(r.runs);
}

class SampleRing {
public:
    // capacity: rounded up to a power of two.  The slots are allocated and touched here, not on
    // the RT thread.
    explicit SampleRing(std::size_t capacity)
        : slots_(new RunSample[std::bit_ceil(capacity)]()), mask_(std::bit_ceil(capacity) - 1) {}

    // Producer (the RT thread): false when the ring is full (the sample is not stored).
    bool push(const RunSample &s) noexcept {
        const uint64_t head = head_.load(std::memory_order_relaxed);
        if (head - tail_seen_ > mask_) {  // full as last seen: look at the consumer's progress
            tail_seen_ = tail_.load(std::memory_order_acquire);
            if (head - tail_seen_ > mask_) return false;
        }
        slots_[head & mask_] = s;
        head_.store(head + 1, std::memory_order_release);
        return true;
    }

    // Consumer (one at a time): applies every sample pushed so far; returns how many.
    std::size_t fold() noexcept {
        const uint64_t head = head_.load(std::memory_order_acquire);
        uint64_t tail = tail_.load(std::memory_order_relaxed);
        const std::size_t n = head - tail;
        for (; tail != head; ++tail) apply(slots_[tail & mask_]);
        tail_.store(tail, std::memory_order_release);
        return n;
    }

    std::size_t capacity() const noexcept { return mask_ + 1; }

private:
    std::unique_ptr<RunSample[]> slots_;
    uint64_t mask_;
    alignas(64) std::atomic<uint64_t> head_{0};  // written by the producer
    uint64_t tail_seen_ = 0;                     // the producer's last look at tail_
    alignas(64) std::atomic<uint64_t> tail_{0};  // written by the consumer
};

}  // namespace irp::stats
