// stats_block.hpp -- the timing statistics of a running set, as laid out in shared memory.
//
// irpd creates one segment per instance, "/indurop.<instance>.stats" (mode 0660): a header, then
// one record per dispatcher (executor) and one per module.  Every field has one writer, with plain
// stores: a dispatcher's record and a module's counters (overruns, missed, ...) its RT thread; a
// module's runs and histograms the stats thread of irpd, which folds the figures each run left in
// its executor's sample ring (stats/sample_ring.hpp) within a millisecond.  Any process may map the
// segment read-only and read live figures without a lock and without ever making the RT thread wait.  The layout is versioned (kVersion): readers
// check magic, version and record_size before trusting anything.  docs/scheduler.md describes it
// field by field for readers in other languages.
#pragma once

#include "stats/histogram.hpp"

#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <initializer_list>

namespace irp::stats {

inline constexpr uint64_t kMagic = 0x3154'4154'5350'5249ull;  // the bytes "IRPSTAT1"
inline constexpr uint32_t kVersion = 2;                       // 2: stats_dropped

// Unused: a free record (room for the modules a hot reload adds); readers skip it.
enum class RecordKind : uint32_t { Dispatcher = 0, Module = 1, Unused = 2 };

// What a module is doing, as the dispatcher sees it.
enum class ModuleState : uint32_t {
    Loaded = 0,    // loaded and initialized, dispatch not yet started
    Running = 1,   // called every period
    Disabled = 2,  // taken out of the slot table after a fault (see last_error)
    Skipped = 3,   // a kind of module this irpd cannot run yet; listed, never called
    Stopped = 4,
    Exited = 5,  // a process module that is not running (crashed or ended, no restart pending)
};

struct alignas(64) TimingRecord {
    char name[64];      // NUL-terminated
    char executor[64];  // the dispatcher thread it runs on ("main", ...)
    RecordKind kind;
    std::atomic<uint32_t> state;  // ModuleState (modules) or 1 while the dispatcher runs
    int32_t priority;
    uint32_t reserved0;
    int64_t period_ns;  // module period, or the basic period for a dispatcher
    int64_t budget_ns;  // 0 = none

    Counter runs;           // run() calls (modules) / slots executed (dispatchers)
    Counter overruns;       // modules: exec above budget; dispatchers: slot work above the basic period
    Counter missed;         // started a whole period (module's, or basic) or more after it was due
    Counter skipped;        // runs / slots dropped by the overrun policy
    Counter errors;         // exceptions thrown out of run()
    Counter caught_up;      // dispatchers: slots started at once, without sleeping, because the
                            // previous slot ended past their due time (catch-up after a late wake-up or an overrun)
    Counter stats_dropped;  // modules: runs whose figures were lost, the sample ring being full (not in
                            // runs nor in the histograms); dispatchers: the sum over their modules

    SignedHistogram jitter;  // Eq. (1): J_n = T0 + n * period - T_n, in ns
    Histogram latency;       // start (wake-up for a dispatcher) minus its planned time, in ns
    Histogram exec;          // execution time of run() / of the slot's whole work, in ns
};

struct alignas(64) Header {
    uint64_t magic;
    uint32_t version;
    uint32_t header_size;   // sizeof(Header)
    uint32_t record_size;   // sizeof(TimingRecord)
    uint32_t record_count;  // dispatchers first, then modules and unused records, in any order
    int64_t pid;            // the irpd that owns the segment
    int64_t basic_ns;
    int64_t macro_ns;
    std::atomic<uint32_t> realtime;    // 1 = every dispatcher thread got SCHED_FIFO
    std::atomic<uint32_t> running;     // 1 while the dispatchers run
    std::atomic<int64_t> started_ns;   // CLOCK_MONOTONIC time of slot 0 (T0 of the dispatcher)
    std::atomic<int64_t> finished_ns;  // when the main dispatcher's last slot ended (0 while running)
    Counter cycles;                    // basic periods completed by the main dispatcher
    char set_path[512];                // module.xml of the running set
};

static_assert(std::is_standard_layout_v<TimingRecord>, "TimingRecord is read by other processes");
static_assert(std::is_standard_layout_v<Header>, "Header is read by other processes");
static_assert(sizeof(Header) % 64 == 0, "records start on a cache line");
static_assert(sizeof(TimingRecord) % 64 == 0, "records do not share cache lines");

// Zeroes the counters and empties the histograms of a record.
inline void resetFigures(TimingRecord &r) noexcept {
    for (Counter *c : {&r.runs, &r.overruns, &r.missed, &r.skipped, &r.errors, &r.caught_up, &r.stats_dropped})
        c->store(0, std::memory_order_relaxed);
    r.jitter.reset();
    r.latency.reset();
    r.exec.reset();
}

inline std::size_t blockSize(std::size_t records) { return sizeof(Header) + records * sizeof(TimingRecord); }

inline TimingRecord *records(Header *h) {
    return reinterpret_cast<TimingRecord *>(reinterpret_cast<char *>(h) + sizeof(Header));
}
inline const TimingRecord *records(const Header *h) {
    return reinterpret_cast<const TimingRecord *>(reinterpret_cast<const char *>(h) + sizeof(Header));
}

}  // namespace irp::stats
