// reactor_proc.cpp -- the sporadic-reaction benchmark's sporadic process module (Figure 8's
// shape): irpd's event handler releases it every basic period; after each release it checks its
// own condition (the event of shared/sporadic.glb raised since it last looked) and, when true,
// records the time waitPeriod() returned minus the raise time (the reaction time) and in which
// basic period it was released relative to the one that raised the event (0 = the same).
// When irpd stops it, it prints both (bench_hist.hpp's text form) on stdout.
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include "common/bench_hist.hpp"

#include <cstdio>

namespace {
bench::Histogram g_reaction;
}

int main() {
    const bool locked = bench::lockMemory();
    if (irp::initPeriodExe() != 0) return 1;
    uint64_t seen = sporadic::seq;
    uint64_t same = 0, next = 0, later = 0, lost = 0, releases = 0;
    while (irp::waitPeriod() == 0) {
        const int64_t woke = bench::nowNs();
        ++releases;
        const uint64_t seq = sporadic::seq;
        if (seq == seen) continue;  // the condition is false
        const int64_t raised = sporadic::raised_ns;
        const uint64_t raised_cycle = sporadic::raised_cycle;
        if (sporadic::seq != seq) continue;  // raised again while reading: take it at the next release
        g_reaction.record(woke - raised);
        const uint64_t delta = irp::cycle().count - raised_cycle;
        (delta == 0 ? same : delta == 1 ? next : later) += 1;
        if (seq - seen > 1) lost += seq - seen - 1;
        seen = seq;
    }
    g_reaction.print(stdout, "sporadic_process");
    std::printf("@info sporadic_process same_period=%llu next_period=%llu later=%llu lost=%llu releases=%llu "
                "mlockall=%d\n",
                static_cast<unsigned long long>(same), static_cast<unsigned long long>(next),
                static_cast<unsigned long long>(later), static_cast<unsigned long long>(lost),
                static_cast<unsigned long long>(releases), locked ? 1 : 0);
    std::fflush(stdout);
    return 0;
}
