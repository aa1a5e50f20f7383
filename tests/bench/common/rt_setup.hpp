// rt_setup.hpp -- what the benchmark's two-process programs (signal_wakeup, release_variants) set up
// alike: SCHED_FIFO, pinning to one CPU, absolute times as timespec, and the --duration option.
#pragma once

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

// --duration's value: positive seconds up to 1e6, else 0.
inline double seconds(const char *text) {
    char *end = nullptr;
    const double s = std::strtod(text, &end);
    return end && !*end && s > 0 && s <= 1e6 ? s : 0;
}

}  // namespace bench
