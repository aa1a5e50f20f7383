// signal_wakeup.cpp -- the benchmark's contrast for process modules: the paper's original design,
// in which the dispatcher wakes a process with a SIGNAL ("send signal to each process", Figure 6;
// "wait signal from event handler", Figure 8), instead of irpd's futex handshake.
//
//   signal_wakeup --period-ns N --duration S [--cpu C] [--rt-priority P] [--unbounded]
//
// Two single-threaded processes pinned to the same CPU C, both mlockall'd:
//   dispatcher (SCHED_FIFO P): sleeps until T0 + n * period (clock_nanosleep TIMER_ABSTIME), then
//     sigqueue(worker, SIGRTMIN, due time) and waits (sigtimedwait, bounded by the end of the period)
//     for the worker's "done" (SIGRTMIN+1 carrying the same due time) -- as irpd releases a periodic
//     process and awaits it.  A wake-up a whole period late skips to the period due now (as irpd's
//     --overrun-policy skip and cyclictest do); a release is not sent while the last one is not done.
//   worker (SCHED_FIFO P-1): blocks in sigwaitinfo(SIGRTMIN); on return, wake-up latency = now - the
//     due time the signal carries; then it sends "done".
// --unbounded: the dispatcher waits for "done" without a time bound (sigwaitinfo): no timer is armed
// before the switch to the worker, which shows what arming one costs on this machine (irpd's
// release of a process, like the default here, waits with a bound).
// The signals are blocked in both processes and taken only by sigwaitinfo/sigtimedwait (no handler).
// At the end the worker, then the dispatcher, print their histograms in bench_hist.hpp's text form:
//   signal_wake        the worker's wake-up latency (the figure compared with a process module's)
//   signal_dispatcher  the dispatcher's own wake-up latency (woke - due)
//   signal_exec        release (just before sigqueue) -> "done" received, as irpd's exec of a process
// and @info lines with the counters.
#include "common/bench_hist.hpp"
#include "common/cli.hpp"
#include "common/rt_setup.hpp"

#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cinttypes>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>

namespace {

bench::Histogram g_wake, g_dispatcher, g_exec;

[[noreturn]] void usage(const char *why) {
    if (why) std::fprintf(stderr, "signal_wakeup: %s\n", why);
    std::fprintf(stderr, "usage: signal_wakeup --period-ns N --duration S [--cpu C] [--rt-priority P] [--unbounded]\n");
    std::exit(2);
}

using bench::fifo;
using bench::toTimespec;

void send(pid_t to, int sig, int64_t value) {
    sigval v{};
    v.sival_ptr = reinterpret_cast<void *>(static_cast<intptr_t>(value));
    sigqueue(to, sig, v);
}

int64_t valueOf(const siginfo_t &info) {
    return static_cast<int64_t>(reinterpret_cast<intptr_t>(info.si_value.sival_ptr));
}

// The worker: the "process module" of the signal-based design.
int worker(pid_t dispatcher, int priority) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    std::string notes;
    const bool locked = bench::lockMemory();
    const bool rt = fifo(priority, notes, "worker");
    const int release = SIGRTMIN, stop = SIGRTMIN + 2;
    sigset_t wait_for;
    sigemptyset(&wait_for);
    sigaddset(&wait_for, release);
    sigaddset(&wait_for, stop);
    send(dispatcher, SIGRTMIN + 1, -1);  // ready
    uint64_t wakes = 0;
    for (;;) {
        siginfo_t info{};
        const int sig = sigwaitinfo(&wait_for, &info);
        const int64_t woke = bench::nowNs();
        if (sig < 0) continue;  // EINTR
        if (sig == stop) break;
        const int64_t due = valueOf(info);
        g_wake.record(woke - due);
        ++wakes;
        send(dispatcher, SIGRTMIN + 1, due);  // done
    }
    bench::printWorkerReport(g_wake, "signal_wake", wakes, rt, locked, notes);
    return 0;
}

}  // namespace

int main(int argc, char **argv) {
    bench::GridOptions options;
    bool bounded = true;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--help" || a == "-h") usage(nullptr);
        if (a == "--unbounded") {
            bounded = false;
            continue;
        }
        if (i + 1 >= argc) usage(("option " + a + " needs a value").c_str());
        if (!bench::gridOption("signal_wakeup", a, argv[++i], options, 99)) usage(("unknown option " + a).c_str());
    }
    if (options.period == 0 || options.duration == 0) usage("--period-ns and --duration are required");
    const int64_t period = options.period;
    const double duration = options.duration;
    const int cpu = options.cpu, priority = options.priority;

    const int release = SIGRTMIN, done = SIGRTMIN + 1, stop = SIGRTMIN + 2;
    sigset_t ours;
    sigemptyset(&ours);
    sigaddset(&ours, release);
    sigaddset(&ours, done);
    sigaddset(&ours, stop);
    sigprocmask(SIG_BLOCK, &ours, nullptr);  // inherited by the worker: taken only by sigwaitinfo
    if (!bench::pinTo("signal_wakeup", cpu)) return 1;
    std::fflush(stdout);
    const pid_t parent = getpid();
    const pid_t child = fork();
    if (child < 0) {
        std::fprintf(stderr, "signal_wakeup: fork: %s\n", std::strerror(errno));
        return 1;
    }
    if (child == 0) std::exit(worker(parent, priority - 1));

    // The dispatcher, set up as irpd's RT thread.
    std::string notes;
    prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);
    const bool locked = bench::lockMemory();
    bool rt = fifo(priority, notes, "dispatcher");
    sigset_t done_set;
    sigemptyset(&done_set);
    sigaddset(&done_set, done);
    siginfo_t info{};
    const timespec ready_wait{5, 0};
    if (sigtimedwait(&done_set, &info, &ready_wait) != done) {
        std::fprintf(stderr, "signal_wakeup: the worker did not report ready within 5 s\n");
        kill(child, SIGKILL);
        waitpid(child, nullptr, 0);
        return 1;
    }

    const auto total = static_cast<uint64_t>(duration * 1e9) / static_cast<uint64_t>(period);
    uint64_t cycles = 0, releases = 0, overruns = 0, not_ready = 0;
    bool pending = false;  // a release whose "done" has not come back
    int64_t pending_due = 0;
    bench::Grid grid{bench::nowNs() + 2'000'000, period, total};
    for (uint64_t n = 0; n < total; ++n, ++cycles) {
        const int64_t due = grid.wake(n, g_dispatcher);
        if (pending) {  // the worker is still on an earlier release: irpd would not release it either
            siginfo_t late_done{};
            const timespec zero{0, 0};
            while (sigtimedwait(&done_set, &late_done, &zero) == done)
                if (valueOf(late_done) == pending_due) pending = false;
            if (pending) {
                ++not_ready;
                continue;
            }
        }
        const int64_t released = bench::nowNs();
        send(child, release, due);
        ++releases;
        pending = true;
        pending_due = due;
        // Await "done", bounded by the end of this basic period (irpd: by the budget, else the period).
        const int64_t until = due + period;
        for (;;) {
            const int64_t left = until - bench::nowNs();
            if (bounded && left <= 0) {
                ++overruns;
                break;
            }
            const timespec wait = toTimespec(left > 0 ? left : 0);
            siginfo_t got{};
            const int sig = bounded ? sigtimedwait(&done_set, &got, &wait) : sigwaitinfo(&done_set, &got);
            if (sig == done && valueOf(got) == due) {
                const int64_t end = bench::nowNs();
                g_exec.record(end - released);
                if (end > until) ++overruns;  // unbounded: done, but after the period
                pending = false;
                break;
            }
            if (sig < 0 && errno == EAGAIN) {
                ++overruns;
                break;
            }
        }
    }
    send(child, stop, 0);
    int status = 0;
    waitpid(child, &status, 0);
    g_dispatcher.print(stdout, "signal_dispatcher");
    g_exec.print(stdout, "signal_exec");
    std::printf("@info signal_dispatcher cycles=%llu grid=%llu releases=%llu missed=%llu skipped=%llu overruns=%llu "
                "not_ready=%llu bounded=%d realtime=%d mlockall=%d worker_status=%d notes=%s\n",
                static_cast<unsigned long long>(cycles), static_cast<unsigned long long>(total),
                static_cast<unsigned long long>(releases), static_cast<unsigned long long>(grid.missed),
                static_cast<unsigned long long>(grid.skipped), static_cast<unsigned long long>(overruns),
                static_cast<unsigned long long>(not_ready), bounded ? 1 : 0, rt ? 1 : 0, locked ? 1 : 0,
                WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), notes.empty() ? "-" : notes.c_str());
    std::fflush(stdout);
    return WIFEXITED(status) && WEXITSTATUS(status) == 0 ? 0 : 1;
}
