// tick_reader.cpp -- a periodic process module for test_process_release that checks, in every
// period, that it runs only after its release: irp::cycle()'s count moves forward, its due time
// is on the grid and has passed, and test.cell.tick (written by tick_writer in each slot) is
//   --after:  this release's count (the writer comes before it in the slot and has run), or
//   --first:  from its previous release's count to this one's minus 1 (the writer comes after it:
//             it ran in the earlier slots and not yet in this one).
// A release the machine held off until the next slot was due (an overrun: the next slot's writer
// may have run meanwhile) is only checked for a tick at or past what the slot's writer wrote; the
// time is read after the tick, so a tick read before the next due time is checked exactly.
// At stop it prints "tick_reader: releases=N bad=B", after at most 5 lines saying what was wrong.
#include <indurop/generated.h>
#include <indurop/indurop.h>

#include <time.h>

#include <cstdint>
#include <cstdio>
#include <cstring>

namespace {
int64_t nowNs() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}
}  // namespace

int main(int argc, char *argv[]) {
    setvbuf(stdout, nullptr, _IOLBF, 0);
    const bool first = argc > 1 && std::strcmp(argv[1], "--first") == 0;
    if (irp::initPeriodExe() != 0) return 2;
    unsigned long releases = 0, bad = 0;
    uint64_t last = 0;
    int64_t epoch = 0;
    auto wrong = [&](const char *what, uint64_t count, long long seen) {
        if (++bad <= 5)
            std::printf("bad: release of cycle %llu: %s (%lld)\n", static_cast<unsigned long long>(count), what, seen);
    };
    while (irp::waitPeriod() == 0) {
        const int64_t now = nowNs();
        const irp::Cycle c = irp::cycle();
        const uint32_t tick = test::cell::tick;
        const bool overran = nowNs() >= c.planned_ns + c.basic_ns;
        const auto count = static_cast<uint32_t>(c.count);
        if (releases && c.count <= last)
            wrong("count did not move forward from the last release", c.count, static_cast<long long>(last));
        if (releases && c.planned_ns - static_cast<int64_t>(c.count) * c.basic_ns != epoch)
            wrong("due time off the grid", c.count, c.planned_ns);
        if (now < c.planned_ns) wrong("running before its due time", c.count, c.planned_ns - now);
        if (!first && (overran ? tick < count : tick != count)) wrong("tick is not this slot's", c.count, tick);
        if (first && releases && (tick < static_cast<uint32_t>(last) || (!overran && tick >= count)))
            wrong("tick is not from the slots between its releases", c.count, tick);
        if (!releases) epoch = c.planned_ns - static_cast<int64_t>(c.count) * c.basic_ns;
        last = c.count;
        ++releases;
    }
    std::printf("tick_reader: releases=%lu bad=%lu\n", releases, bad);
    return 0;
}
