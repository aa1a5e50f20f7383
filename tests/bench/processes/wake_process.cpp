// wake_process.cpp -- the benchmark's periodic process module: the minimal period loop
// (irp::initPeriodExe(); while (irp::waitPeriod() == 0) {}) that also measures its own wake-up
// latency: the time waitPeriod() returns minus irp::cycle().planned_ns, the due time of the basic
// period that released it.  When irpd stops it (waitPeriod() returns -1) it prints the histogram
// (tests/bench/common/bench_hist.hpp's text form), which reaches irpd's stdout as "[name] @hist ...".
#include <indurop/indurop.h>

#include "common/bench_hist.hpp"

#include <cstdio>

namespace {
bench::Histogram g_wake;  // static: no allocation, touched before the loop by mlockall
}

int main() {
    const bool locked = bench::lockMemory();
    if (irp::initPeriodExe() != 0) return 1;
    uint64_t releases = 0, gaps = 0, last = 0;
    while (irp::waitPeriod() == 0) {
        const int64_t woke = bench::nowNs();
        const irp::Cycle &c = irp::cycle();
        g_wake.record(woke - c.planned_ns);
        if (releases && c.count != last + 1) ++gaps;  // a basic period in which it was not released
        last = c.count;
        ++releases;
    }
    g_wake.print(stdout, "process_wake");
    std::printf("@info process_wake releases=%llu gaps=%llu mlockall=%d\n", static_cast<unsigned long long>(releases),
                static_cast<unsigned long long>(gaps), locked ? 1 : 0);
    std::fflush(stdout);
    return 0;
}
