// release_variants.cpp -- the benchmark's alternatives to irpd's release of a process module: the
// same futex handshake as irpd's control slot (release_seq + 1 and FUTEX_WAKE; the process reports
// done_seq and FUTEX_WAKEs), with the dispatcher's wait for "done" made in different ways, so that
// their cost can be compared in one run with irpd's own process module and thread module.
//
//   release_variants --mode M --period-ns N --duration S [--cpu C] [--rt-priority P] [--spin-ns N]
//
// Two single-threaded processes pinned to CPU C, both mlockall'd, sharing one anonymous mapping:
//   dispatcher (SCHED_FIFO P, timer slack 1 ns): sleeps until T0 + n * period (clock_nanosleep
//     TIMER_ABSTIME), releases the worker and waits for its done word as the mode says.  A wake-up
//     a whole period late skips to the period due now (irpd --overrun-policy skip); a worker still
//     on its last release is not released (irpd counts it missed).
//   worker (SCHED_FIFO P-1, or P+1 in mode "above", or P in mode "yield"): FUTEX_WAIT on the release
//     word; on return, wake-up latency = now - the due time the dispatcher wrote; then done.
// Modes (the wait for "done", bounded by the end of the basic period unless said otherwise):
//   bounded    irpd's wait before this change: irp::futex::waitWhileEqual, a FUTEX_WAIT with a
//              relative timeout (an hrtimer armed before the switch to the worker, cancelled after)
//   bitset     FUTEX_WAIT_BITSET with the absolute end of the period (no clock read, same hrtimer)
//   unbounded  FUTEX_WAIT without a timeout: no hrtimer (nothing bounds a hung worker)
//   spin       spin on the done word for --spin-ns first, then as bounded (the worker is on the same
//              CPU at a lower priority: it cannot run while the dispatcher spins)
//   above      the worker one priority ABOVE the dispatcher: FUTEX_WAKE switches to it at once, and
//              the dispatcher finds the done word set when it runs again (then as bounded)
//   yield      the worker at the dispatcher's priority: the dispatcher sched_yield()s to it after
//              the wake (then as bounded)
//   timer      irpd's release now: the worker first sleeps until the next due time by itself
//              (FUTEX_WAIT_BITSET on the release word, announced in wake_ns), then without a timer;
//              the dispatcher makes the FUTEX_WAKE only when wake_ns is 0 or after the release
//              (then as unbounded)
//   timer_wake the same, with the FUTEX_WAKE made at every release (what leaving it out saves)
//   timer_spin as timer, but the worker's timer is set --spin-ns before the due time and it then
//              spins on the release word (at most until 20 µs after the due time) instead of
//              sleeping: its CPU is kept busy, not idle, when the dispatcher's timer fires
//   prearmed   the worker one priority ABOVE the dispatcher and asleep until the next due time by
//              itself; the dispatcher makes each release one period AHEAD, once the worker is done
//              with the last (release_seq + 1 with its due time, no FUTEX_WAKE): at the due time the
//              worker's own timer starts it before the dispatcher, which then finds it done (then
//              as unbounded).  The release is irpd's decision still, only handed over early.
// At the end the worker, then the dispatcher, print histograms in bench_hist.hpp's text form:
//   variant_wake        the worker's wake-up latency
//   variant_dispatcher  the dispatcher's own wake-up latency (woke - due)
//   variant_exec        release (just before the wake) -> done seen by the dispatcher
// and @info lines with the counters.
#include "common/bench_hist.hpp"
#include "common/cli.hpp"
#include "common/rt_setup.hpp"
#include "sdk/sync.hpp"

#include <sched.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>

namespace {

enum class Mode { Bounded, Bitset, Unbounded, Spin, Above, Yield, Timer, TimerWake, TimerSpin, Prearmed };

struct Shared {
    uint32_t release_seq = 0;
    uint32_t done_seq = 0;
    uint32_t stop = 0;
    uint32_t ready = 0;
    int64_t due = 0;
    int64_t next_due = 0;  // timer modes: the due time of the next release
    int64_t wake_ns = 0;   // timer modes: the worker's wait ends by itself then (0: only a wake ends it)
};

bench::Histogram g_wake, g_dispatcher, g_exec;

[[noreturn]] void usage(const char *why) {
    if (why) std::fprintf(stderr, "release_variants: %s\n", why);
    std::fprintf(
        stderr,
        "usage: release_variants --mode bounded|bitset|unbounded|spin|above|yield|timer|timer_wake|timer_spin|prearmed "
        "--period-ns N --duration S [--cpu C] [--rt-priority P] [--spin-ns N]\n");
    std::exit(2);
}

int64_t number(const char *option, const char *text, int64_t min, int64_t max) {
    return bench::number("release_variants", option, text, min, max);
}

using bench::fifo;
using bench::toTimespec;

std::atomic_ref<uint32_t> word(uint32_t &w) { return std::atomic_ref<uint32_t>(w); }
std::atomic_ref<int64_t> word(int64_t &w) { return std::atomic_ref<int64_t>(w); }

constexpr int64_t kSpinPastDue = 20'000;  // timer_spin: the worker spins at most this long past the due time

// The timer modes' wait for the next release, as irp::waitPeriod() makes it; with spin_ns > 0
// (timer_spin) the timer is set that much earlier and the worker then spins.
void waitTimed(Shared &s, uint32_t seq, int64_t &wake, int64_t spin_ns) {
    const int64_t at = wake ? wake - spin_ns : 0;
    word(s.wake_ns).store(at, std::memory_order_seq_cst);
    if (word(s.release_seq).load(std::memory_order_seq_cst) != seq) return;
    if (!at) {
        irp::futex::wait(&s.release_seq, seq);
        return;
    }
    irp::futex::waitUntil(&s.release_seq, seq, at);
    if (spin_ns)
        while (word(s.release_seq).load(std::memory_order_acquire) == seq && bench::nowNs() < wake + kSpinPastDue)
            __builtin_ia32_pause();
    wake = 0;
}

// prearmed: the worker's loop.  A release made ahead (release_seq moved, its due time in `due`) is
// served at its due time: the worker sleeps until then on its own timer (a FUTEX_WAIT_BITSET on the
// stop word, which only the end of the run changes), then runs.  Nothing released yet: it sleeps
// until the next due time it was told of, and without a timer after that.
uint64_t servePrearmed(Shared &s, uint32_t seen) {
    uint64_t wakes = 0;
    int64_t next = 0;
    while (!word(s.stop).load(std::memory_order_acquire)) {
        const uint32_t seq = word(s.release_seq).load(std::memory_order_acquire);
        if (seq == seen) {  // wake_ns says the dispatcher whether to wake it (0) or not: as waitTimed
            if (next && bench::nowNs() >= next) next = 0;
            word(s.wake_ns).store(next, std::memory_order_seq_cst);
            if (word(s.release_seq).load(std::memory_order_seq_cst) != seq) continue;
            if (next)
                irp::futex::waitUntil(&s.release_seq, seq, next);
            else
                irp::futex::wait(&s.release_seq, seq);
            next = 0;
            continue;
        }
        const int64_t due = word(s.due).load(std::memory_order_relaxed);
        if (bench::nowNs() < due) {
            irp::futex::waitUntil(&s.stop, 0, due);
            continue;
        }
        const int64_t woke = bench::nowNs();
        seen = seq;
        g_wake.record(woke - due);
        ++wakes;
        next = due + word(s.next_due).load(std::memory_order_relaxed);
        word(s.done_seq).store(seq, std::memory_order_release);
        irp::futex::wakeAll(&s.done_seq);
    }
    return wakes;
}

int worker(Shared &s, int priority, bool timed, int64_t spin_ns, bool prearmed) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    std::string notes;
    const bool locked = bench::lockMemory();
    const bool rt = fifo(priority, notes, "worker");
    uint32_t seen = word(s.release_seq).load(std::memory_order_acquire);
    word(s.ready).store(1, std::memory_order_release);
    irp::futex::wakeAll(&s.ready);
    uint64_t wakes = prearmed ? servePrearmed(s, seen) : 0;
    int64_t wake = 0;
    while (!prearmed) {
        if (word(s.stop).load(std::memory_order_acquire)) break;
        const uint32_t seq = word(s.release_seq).load(std::memory_order_acquire);
        if (seq == seen) {
            if (timed)
                waitTimed(s, seq, wake, spin_ns);
            else
                irp::futex::wait(&s.release_seq, seq);
            continue;
        }
        const int64_t woke = bench::nowNs();
        seen = seq;
        wake = word(s.next_due).load(std::memory_order_relaxed);
        g_wake.record(woke - std::atomic_ref<int64_t>(s.due).load(std::memory_order_relaxed));
        ++wakes;
        word(s.done_seq).store(seq, std::memory_order_release);
        irp::futex::wakeAll(&s.done_seq);
    }
    bench::printWorkerReport(g_wake, "variant_wake", wakes, rt, locked, notes);
    return 0;
}

// FUTEX_WAIT_BITSET until *w != expected or the absolute CLOCK_MONOTONIC time `until`.
bool waitAbsolute(uint32_t *w, uint32_t expected, int64_t until) {
    const timespec at = toTimespec(until);
    while (word(*w).load(std::memory_order_acquire) == expected) {
        if (syscall(SYS_futex, w, FUTEX_WAIT_BITSET, expected, &at, nullptr, FUTEX_BITSET_MATCH_ANY) != 0 &&
            errno == ETIMEDOUT)
            return word(*w).load(std::memory_order_acquire) != expected;
    }
    return true;
}

Mode parseMode(const std::string &m) {
    if (m == "bounded") return Mode::Bounded;
    if (m == "bitset") return Mode::Bitset;
    if (m == "unbounded") return Mode::Unbounded;
    if (m == "spin") return Mode::Spin;
    if (m == "above") return Mode::Above;
    if (m == "yield") return Mode::Yield;
    if (m == "timer") return Mode::Timer;
    if (m == "timer_wake") return Mode::TimerWake;
    if (m == "timer_spin") return Mode::TimerSpin;
    if (m == "prearmed") return Mode::Prearmed;
    usage(("unknown mode " + m).c_str());
}

// prearmed: the dispatcher's loop.  At each due time it finds the release it made a period ahead
// served (the worker, above it, ran first on its own timer) and makes the next one; a release not
// served yet is waited for (unbounded, as irpd's wait for done).  Release -> done is not measured
// here (the release is made a period ahead); `not_ready` counts releases the dispatcher found not
// yet served at its own wake-up, `overruns` those not done by the end of their period.
struct PrearmedCounts {
    uint64_t releases, overruns, not_ready;
};
PrearmedCounts runPrearmed(Shared &s, bench::Grid &grid, uint64_t total, int64_t period) {
    PrearmedCounts c{0, 0, 0};
    word(s.next_due).store(period, std::memory_order_relaxed);  // the worker's next due: its last + this
    uint32_t armed = 0;
    for (uint64_t n = 0; n < total; ++n) {
        const int64_t due = grid.wake(n, g_dispatcher);
        if (armed) {  // the release armed for this due time: served (the worker ran first) or awaited
            if (word(s.done_seq).load(std::memory_order_acquire) != armed) ++c.not_ready;
            irp::futex::waitWhileEqual(&s.done_seq, armed - 1, 0);
            if (bench::nowNs() > due + period) ++c.overruns;
        }
        // the next release, a period ahead: its due time first, then the word the worker reads
        word(s.due).store(due + period, std::memory_order_relaxed);
        armed = word(s.release_seq).load(std::memory_order_relaxed) + 1;
        word(s.release_seq).store(armed, std::memory_order_seq_cst);
        // a worker asleep without a timer (the first release, or it woke before this late one) is woken
        const int64_t wakes_at = word(s.wake_ns).load(std::memory_order_seq_cst);
        if (wakes_at == 0 || wakes_at <= bench::nowNs()) irp::futex::wakeAll(&s.release_seq);
        ++c.releases;
    }
    return c;
}

}  // namespace

int main(int argc, char **argv) {
    bench::GridOptions options;
    int64_t spin_ns = 2000;
    std::string mode_name;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--help" || a == "-h") usage(nullptr);
        if (i + 1 >= argc) usage(("option " + a + " needs a value").c_str());
        const char *v = argv[++i];
        if (bench::gridOption("release_variants", a, v, options, 98)) continue;
        if (a == "--mode")
            mode_name = v;
        else if (a == "--spin-ns")
            spin_ns = number("--spin-ns", v, 0, 1'000'000);
        else
            usage(("unknown option " + a).c_str());
    }
    if (options.period == 0 || options.duration == 0 || mode_name.empty())
        usage("--mode, --period-ns and --duration are required");
    const int64_t period = options.period;
    const double duration = options.duration;
    const int cpu = options.cpu, priority = options.priority;
    const Mode mode = parseMode(mode_name);

    if (!bench::pinTo("release_variants", cpu)) return 1;
    void *mem = mmap(nullptr, sizeof(Shared), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (mem == MAP_FAILED) {
        std::fprintf(stderr, "release_variants: mmap: %s\n", std::strerror(errno));
        return 1;
    }
    Shared &s = *new (mem) Shared{};
    std::fflush(stdout);
    const int worker_priority = mode == Mode::Above || mode == Mode::Prearmed ? priority + 1
                                : mode == Mode::Yield                         ? priority
                                                                              : priority - 1;
    const pid_t child = fork();
    if (child < 0) {
        std::fprintf(stderr, "release_variants: fork: %s\n", std::strerror(errno));
        return 1;
    }
    const bool timed = mode == Mode::Timer || mode == Mode::TimerWake || mode == Mode::TimerSpin;
    if (child == 0)
        std::exit(worker(s, worker_priority, timed, mode == Mode::TimerSpin ? spin_ns : 0, mode == Mode::Prearmed));

    std::string notes;
    prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);
    const bool locked = bench::lockMemory();
    const bool rt = fifo(priority, notes, "dispatcher");
    if (!irp::futex::waitWhileEqual(&s.ready, 0, 5'000'000'000)) {
        std::fprintf(stderr, "release_variants: the worker did not report ready within 5 s\n");
        kill(child, SIGKILL);
        waitpid(child, nullptr, 0);
        return 1;
    }

    const auto total = static_cast<uint64_t>(duration * 1e9) / static_cast<uint64_t>(period);
    bench::Grid grid{bench::nowNs() + 2'000'000, period, total};
    uint64_t cycles = 0, releases = 0, overruns = 0, not_ready = 0;
    if (mode == Mode::Prearmed) {
        const auto [r, o, nr] = runPrearmed(s, grid, total, period);
        releases = r, overruns = o, not_ready = nr;
        cycles = total;
    }
    for (uint64_t n = 0; mode != Mode::Prearmed && n < total; ++n, ++cycles) {
        const int64_t due = grid.wake(n, g_dispatcher);
        const uint32_t served = word(s.release_seq).load(std::memory_order_relaxed);
        if (word(s.done_seq).load(std::memory_order_acquire) != served) {
            ++not_ready;  // still on its last release
            continue;
        }
        const int64_t released = bench::nowNs();
        word(s.due).store(due, std::memory_order_relaxed);
        word(s.next_due).store(due + period, std::memory_order_relaxed);
        word(s.release_seq).store(served + 1, std::memory_order_seq_cst);
        const int64_t wakes_at =
            mode == Mode::Timer || mode == Mode::TimerSpin ? word(s.wake_ns).load(std::memory_order_seq_cst) : 0;
        if (wakes_at == 0 || wakes_at > released) irp::futex::wakeAll(&s.release_seq);
        const int64_t until = due + period;
        bool done = false;
        switch (mode) {
        case Mode::Timer:
        case Mode::TimerWake:
        case Mode::TimerSpin:
        case Mode::Unbounded: done = irp::futex::waitWhileEqual(&s.done_seq, served, 0); break;
        case Mode::Bitset: done = waitAbsolute(&s.done_seq, served, until); break;
        case Mode::Spin: {
            const int64_t spin_until = released + spin_ns;
            while (!(done = word(s.done_seq).load(std::memory_order_acquire) != served) && bench::nowNs() < spin_until)
                __builtin_ia32_pause();
            if (done) break;
            [[fallthrough]];
        }
        default:
            if (mode == Mode::Yield) sched_yield();
            done =
                until - bench::nowNs() > 0 && irp::futex::waitWhileEqual(&s.done_seq, served, until - bench::nowNs());
        }
        const int64_t end = bench::nowNs();
        if (done) g_exec.record(end - released);
        if (!done || end > until) ++overruns;
        ++releases;
    }
    word(s.stop).store(1, std::memory_order_release);
    irp::futex::wakeAll(&s.release_seq);
    int status = 0;
    waitpid(child, &status, 0);
    g_dispatcher.print(stdout, "variant_dispatcher");
    g_exec.print(stdout, "variant_exec");
    std::printf("@info variant_dispatcher mode=%s cycles=%llu grid=%llu releases=%llu missed=%llu skipped=%llu "
                "overruns=%llu not_ready=%llu realtime=%d mlockall=%d worker_status=%d notes=%s\n",
                mode_name.c_str(), static_cast<unsigned long long>(cycles), static_cast<unsigned long long>(total),
                static_cast<unsigned long long>(releases), static_cast<unsigned long long>(grid.missed),
                static_cast<unsigned long long>(grid.skipped), static_cast<unsigned long long>(overruns),
                static_cast<unsigned long long>(not_ready), rt ? 1 : 0, locked ? 1 : 0,
                WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), notes.empty() ? "-" : notes.c_str());
    std::fflush(stdout);
    return WIFEXITED(status) && WEXITSTATUS(status) == 0 ? 0 : 1;
}
