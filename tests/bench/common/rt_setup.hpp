// rt_setup.hpp -- what the benchmark's two-process programs (signal_wakeup, release_variants) set up
// alike: SCHED_FIFO, pinning to one CPU, absolute times as timespec, and the --duration option.
#pragma once

#include "common/bench_hist.hpp"
#include "common/cli.hpp"

#include <sched.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>

namespace bench {

inline timespec toTimespec(int64_t ns) {
    return timespec{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
}

// SCHED_FIFO at `priority` for the calling process; a refusal is noted in `notes` as "who: why; ".
inline bool fifo(int priority, std::string &notes, const char *who) {
    sched_param param{};
    param.sched_priority = priority;
    if (sched_setscheduler(0, SCHED_FIFO, &param) != 0) {
        notes += std::string(who) + ": SCHED_FIFO refused: " + std::strerror(errno) + "; ";
        return false;
    }
    return true;
}

// Pins the calling process to `cpu` (< 0: leaves it); false after saying why on stderr.
inline bool pinTo(const char *program, int cpu) {
    if (cpu < 0) return true;
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    if (sched_setaffinity(0, sizeof set, &set) == 0) return true;
    std::fprintf(stderr, "%s: cannot pin to CPU %d: %s\n", program, cpu, std::strerror(errno));
    return false;
}

// The options both programs take.
struct GridOptions {
    int64_t period = 0;   // --period-ns
    double duration = 0;  // --duration, seconds
    int cpu = -1;         // --cpu
    int priority = 80;    // --rt-priority, the dispatcher's
};

// Takes `option value` into `o` when it is one of GridOptions' (false when it is not); a bad value
// is said on stderr with the program's name, and the program exits 2.
inline bool gridOption(const char *program, const std::string &option, const char *value, GridOptions &o,
                       int max_priority) {
    if (option == "--period-ns") {
        o.period = number(program, "--period-ns", value, 10'000, 1'000'000'000);
    } else if (option == "--cpu") {
        o.cpu = static_cast<int>(number(program, "--cpu", value, 0, CPU_SETSIZE - 1));
    } else if (option == "--rt-priority") {
        o.priority = static_cast<int>(number(program, "--rt-priority", value, 2, max_priority));
    } else if (option == "--duration") {
        char *end = nullptr;
        o.duration = std::strtod(value, &end);
        if (!end || *end || !(o.duration > 0) || o.duration > 1e6) {
            std::fprintf(stderr, "%s: --duration: expected positive seconds, not '%s'\n", program, value);
            std::exit(2);
        }
    } else {
        return false;
    }
    return true;
}

// The dispatcher's absolute grid, as irpd's: period n is due at t0 + n * period.
struct Grid {
    int64_t t0 = 0, period = 0;
    uint64_t total = 0;                // periods in the run
    uint64_t missed = 0, skipped = 0;  // wake-ups a whole period late, and the periods they skipped

    // Sleeps until period n is due and records the wake-up's latency; a wake-up a whole period
    // late skips to the period due now (irpd --overrun-policy skip, cyclictest), moving n past the
    // skipped ones.  Returns the due time of the period to serve.
    int64_t wake(uint64_t &n, Histogram &latency) {
        int64_t due = t0 + static_cast<int64_t>(n) * period;
        const timespec at = toTimespec(due);
        while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &at, nullptr) == EINTR) {}
        const int64_t late = nowNs() - due;
        latency.record(late);
        if (late >= period) {
            ++missed;
            auto behind = static_cast<uint64_t>(late / period);
            if (n + behind >= total) behind = total - n - 1;
            skipped += behind;
            n += behind;
            due += static_cast<int64_t>(behind) * period;
        }
        return due;
    }
};

// A worker's closing report, read by rtbench: its wake-up histogram under `label`, then
// "@info <label> wakes=… realtime=… mlockall=… notes=…".
inline void printWorkerReport(const Histogram &wake, const char *label, unsigned long long wakes, bool rt, bool locked,
                              const std::string &notes) {
    wake.print(stdout, label);
    std::printf("@info %s wakes=%llu realtime=%d mlockall=%d notes=%s\n", label, wakes, rt ? 1 : 0, locked ? 1 : 0,
                notes.empty() ? "-" : notes.c_str());
    std::fflush(stdout);
}

}  // namespace bench
