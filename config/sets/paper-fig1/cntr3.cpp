// cntr3.cpp -- Figure 1's cntr3 (100 us, priority 1: first in every slot).  Reports once a
// second from the RT thread through irp::printf, which never blocks.
#include <indurop/indurop.h>

#include <cstdint>

namespace {
uint64_t runs = 0;
}

void onRun() {
    ++runs;
    const irp::Cycle &c = irp::cycle();
    if (c.count % (1'000'000'000 / c.basic_ns) == 0)
        irp::printf("[cntr3] %llu runs, basic period %llu, slot %u\n", static_cast<unsigned long long>(runs),
                    static_cast<unsigned long long>(c.count), c.slot);
}

void onStop() { irp::printf("[cntr3] stop after %llu runs\n", static_cast<unsigned long long>(runs)); }

INDUROP_MODULE(name = "cntr3", run = &::onRun, stop = &::onStop)
