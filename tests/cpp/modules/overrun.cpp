// overrun.cpp -- a thread module that overruns on purpose, for the watchdog tests (test_faults).
// Properties: journal (a file), hang_at (the run that overruns, 1-based; default never),
// hang_ms (how long that run spins; 0 = until safe_outputs() is called, at most 10 s),
// stuck_once=0 to overrun in every run from hang_at on, and poll_abort=1 to poll
// irp::runAbortRequested() in the spin and throw when it turns true (an endless loop that can be
// ended).  It writes "start", "run <n> overran <ms> ms (spin began at <CLOCK_MONOTONIC ns> ns)",
// "run <n> asked to end after <ms> ms", "safe_outputs during run <n>" (or "... while idle"),
// "stop runs=<n>" to the journal.
// Its safe_outputs() is the hook irpd calls when a fault stops the set.
#include <indurop/indurop.h>

#include <time.h>

#include <atomic>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace {
std::string journal;
long hang_at = -1, hang_ms = 0;
bool once = true, poll_abort = false;
std::atomic<long> running{0};  // the run in progress, 0 between runs
std::atomic<bool> safe{false};
unsigned long long runs = 0;

void note(const std::string &line) {
    if (FILE *f = std::fopen(journal.c_str(), "a")) {
        std::fprintf(f, "%s\n", line.c_str());
        std::fclose(f);
    }
}

long long nowNs() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<long long>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}
}  // namespace

extern "C" void initialize(irp::Property const &p) {
    journal = p.get("journal", std::string_view("/dev/null"));
    hang_at = p.get<long>("hang_at", -1);
    hang_ms = p.get<long>("hang_ms", 0);
    once = p.get<int>("stuck_once", 1) != 0;
    poll_abort = p.get<int>("poll_abort", 0) != 0;
}
void start() { note("start"); }
void run() {
    const long n = static_cast<long>(++runs);
    if (n != hang_at && (once || hang_at < 0 || n < hang_at)) return;
    running.store(n);
    const long long begun = nowNs();
    const long long until = begun + (hang_ms > 0 ? hang_ms : 10'000) * 1'000'000;
    while (nowNs() < until && !(hang_ms == 0 && safe.load())) {
        if (poll_abort && irp::runAbortRequested()) {
            running.store(0);
            note("run " + std::to_string(n) + " asked to end after " + std::to_string((nowNs() - begun) / 1'000'000) +
                 " ms");
            throw std::runtime_error("overrun.cpp: endless loop? run " + std::to_string(n) +
                                     " ended at the watchdog's request");
        }
    }
    running.store(0);
    note("run " + std::to_string(n) + " overran " + std::to_string((nowNs() - begun) / 1'000'000) +
         " ms (spin began at " + std::to_string(begun) + " ns)");
}
extern "C" void safe_outputs() {
    const long during = running.load();
    // journaled before the spin is released, so the journal's order is the order things happened
    note(during ? "safe_outputs during run " + std::to_string(during) : std::string("safe_outputs while idle"));
    safe.store(true);
}
void stop() { note("stop runs=" + std::to_string(runs)); }
