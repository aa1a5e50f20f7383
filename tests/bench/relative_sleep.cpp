// relative_sleep.cpp -- the benchmark's counter-example: a periodic loop written the naive way,
// with a RELATIVE sleep of one period after each iteration's work, instead of waking on an
// absolute time grid as irpd (and cyclictest) do.
//
//   relative_sleep --period-ns N --duration S [--cpu C] [--rt-priority P] [--work-ns W]
//
// Same conditions as the irpd run: SCHED_FIFO at P, pinned to CPU C, mlockall.  Each iteration
// spins W ns (the "work"), then clock_nanosleep(CLOCK_MONOTONIC, 0, {period}).  Every wake-up
// overshoot, the work and the time to re-arm the timer add to the period, so the loop runs fewer
// iterations than elapsed/period ("periods lost") and its n-th wake-up drifts ever further from
// the grid T0 + n * period it was meant to follow.
//
// Prints one JSON object on stdout:
//   iterations, elapsed_ns, expected_iterations (= floor(elapsed / period)), periods_lost,
//   drift_ns (last wake-up minus its grid time), drift_ns_per_s,
//   actual_period_ns {mean, min, p50, p99, p999, max}  (time between consecutive wake-ups),
//   overshoot_ns {…}  (actual period minus the requested period: the per-iteration error),
//   grid_lateness_ns {…}  (wake-up minus the grid time; grows without bound: that is the drift).
#include "common/cli.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/prctl.h>

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

namespace {

int64_t now() {
    timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

[[noreturn]] void usage(const char *why) {
    if (why) std::fprintf(stderr, "relative_sleep: %s\n", why);
    std::fprintf(stderr,
                 "usage: relative_sleep --period-ns N --duration S [--cpu C] [--rt-priority P] [--work-ns W]\n");
    std::exit(2);
}

int64_t number(const char *option, const char *text, int64_t min, int64_t max) {
    return bench::number("relative_sleep", option, text, min, max);
}

struct Figures {
    double mean = 0;
    int64_t min = 0, p50 = 0, p99 = 0, p999 = 0, max = 0;
};

// Exact percentiles (nearest rank) of the samples; sorts them.
Figures figures(std::vector<int64_t> &v) {
    Figures f;
    if (v.empty()) return f;
    double sum = 0;
    for (int64_t x : v) sum += static_cast<double>(x);
    std::sort(v.begin(), v.end());
    auto at = [&](double q) {
        auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
        return v[std::clamp<std::size_t>(rank, 1, v.size()) - 1];
    };
    f.mean = sum / static_cast<double>(v.size());
    f.min = v.front();
    f.max = v.back();
    f.p50 = at(0.50);
    f.p99 = at(0.99);
    f.p999 = at(0.999);
    return f;
}

std::string json(const Figures &f) {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "{\"mean\": %.1f, \"min\": %" PRId64 ", \"p50\": %" PRId64 ", \"p99\": %" PRId64
                  ", \"p999\": %" PRId64 ", \"max\": %" PRId64 "}",
                  f.mean, f.min, f.p50, f.p99, f.p999, f.max);
    return buf;
}

}  // namespace

int main(int argc, char **argv) {
    int64_t period = 0, work = 1000;
    double duration = 0;
    int cpu = -1, priority = 80;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--help" || a == "-h") usage(nullptr);
        if (i + 1 >= argc) usage(("option " + a + " needs a value").c_str());
        const char *v = argv[++i];
        if (a == "--period-ns")
            period = number("--period-ns", v, 1000, 1'000'000'000);
        else if (a == "--work-ns")
            work = number("--work-ns", v, 0, 1'000'000'000);
        else if (a == "--cpu")
            cpu = static_cast<int>(number("--cpu", v, 0, CPU_SETSIZE - 1));
        else if (a == "--rt-priority")
            priority = static_cast<int>(number("--rt-priority", v, 1, 99));
        else if (a == "--duration") {
            char *end = nullptr;
            duration = std::strtod(v, &end);
            if (!end || *end || !(duration > 0) || duration > 1e6) usage("--duration: expected positive seconds");
        } else
            usage(("unknown option " + a).c_str());
    }
    if (period == 0 || duration == 0) usage("--period-ns and --duration are required");
    if (work >= period) usage("--work-ns must be shorter than the period");

    // The same RT set-up as irpd's dispatcher thread.
    bool realtime = true;
    std::string notes;
    if (cpu >= 0) {
        cpu_set_t set;
        CPU_ZERO(&set);
        CPU_SET(cpu, &set);
        if (int rc = pthread_setaffinity_np(pthread_self(), sizeof set, &set)) {
            std::fprintf(stderr, "relative_sleep: cannot pin to CPU %d: %s\n", cpu, std::strerror(rc));
            return 1;
        }
    }
    prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
        realtime = false;
        notes += std::string("mlockall failed: ") + std::strerror(errno) + "; ";
    }
    sched_param param{};
    param.sched_priority = priority;
    if (int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param)) {
        realtime = false;
        notes += std::string("SCHED_FIFO refused: ") + std::strerror(rc) + "; ";
    }

    // Samples are kept in memory allocated and touched before the loop (no page fault inside it).
    const auto duration_ns = static_cast<int64_t>(duration * 1e9);
    const auto capacity = static_cast<std::size_t>(duration_ns / period + 16);
    std::vector<int64_t> wakes(capacity, 0);

    const timespec interval{static_cast<time_t>(period / 1'000'000'000), static_cast<long>(period % 1'000'000'000)};
    volatile uint64_t sink = 0;
    const int64_t t0 = now();
    const int64_t end = t0 + duration_ns;
    int64_t woke = t0;
    std::size_t n = 0;  // iterations completed (wake-ups after a sleep)
    for (;;) {
        // the iteration's "work": spin `work` ns from the wake-up
        while (now() - woke < work) sink = sink + 1;
        while (clock_nanosleep(CLOCK_MONOTONIC, 0, &interval, nullptr) == EINTR) {
            // a relative sleep cannot be resumed exactly; a naive loop just sleeps again
        }
        woke = now();
        if (woke > end) break;  // only wake-ups inside the run count, as irpd's cycles do
        if (n < capacity) wakes[n] = woke;
        ++n;
    }
    const int64_t elapsed = duration_ns;
    const std::size_t kept = std::min(n, capacity);

    std::vector<int64_t> actual, overshoot, lateness;
    actual.reserve(kept);
    overshoot.reserve(kept);
    lateness.reserve(kept);
    int64_t previous = t0;
    for (std::size_t i = 0; i < kept; ++i) {
        actual.push_back(wakes[i] - previous);
        overshoot.push_back(wakes[i] - previous - period);
        lateness.push_back(wakes[i] - (t0 + static_cast<int64_t>(i + 1) * period));
        previous = wakes[i];
    }
    const int64_t expected = elapsed / period;
    const int64_t drift = kept ? lateness.back() : 0;
    const Figures fa = figures(actual), fo = figures(overshoot), fl = figures(lateness);

    std::printf(
        "{\"program\": \"relative_sleep\", \"realtime\": %s, \"notes\": \"%s\", \"cpu\": %d, \"rt_priority\": %d,\n"
        " \"period_ns\": %" PRId64 ", \"work_ns\": %" PRId64 ", \"elapsed_ns\": %" PRId64 ",\n"
        " \"iterations\": %zu, \"expected_iterations\": %" PRId64 ", \"periods_lost\": %" PRId64 ",\n"
        " \"drift_ns\": %" PRId64 ", \"drift_ns_per_s\": %.1f,\n"
        " \"actual_period_ns\": %s,\n \"overshoot_ns\": %s,\n \"grid_lateness_ns\": %s}\n",
        realtime ? "true" : "false", notes.c_str(), cpu, priority, period, work, elapsed, n, expected,
        expected - static_cast<int64_t>(n), drift, static_cast<double>(drift) / (static_cast<double>(elapsed) / 1e9),
        json(fa).c_str(), json(fo).c_str(), json(fl).c_str());
    return 0;
}
