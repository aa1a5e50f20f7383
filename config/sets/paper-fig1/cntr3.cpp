// cntr3.cpp -- Figure 1's cntr3 (100 us, priority 1: first in every slot).  It plays the sensor:
// joint[0].x turns by 0.05 degree a period, and event1 (Figure 7) fires at 180 degrees.  Once a
// second it reports from the RT thread through irp::printf, which never blocks.
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include <cstdint>

namespace {
uint64_t runs = 0;
}

void onRun() {
    ++runs;
    joint[0].x += 0.05;
    const irp::Cycle &c = irp::cycle();
    if (c.count % (1'000'000'000 / c.basic_ns) == 0)
        irp::printf("[cntr3] %llu runs, basic period %llu, slot %u, joint[0].x = %.2f\n",
                    static_cast<unsigned long long>(runs), static_cast<unsigned long long>(c.count), c.slot,
                    static_cast<double>(joint[0].x));
}

void onStop() { irp::printf("[cntr3] stop after %llu runs\n", static_cast<unsigned long long>(runs)); }

INDUROP_MODULE(name = "cntr3", run = &::onRun, stop = &::onStop)
