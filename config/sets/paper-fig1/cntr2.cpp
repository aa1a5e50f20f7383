// cntr2.cpp -- Figure 1's cntr2 (100 us, priority 2), written with INDUROP_MODULE as in Figures 4
// and 5: a counter with start and stop hooks.
#include <indurop/indurop.h>

#include <cstdint>
#include <iostream>

namespace {
uint64_t runs = 0;
}

void onStart() { std::cout << "[cntr2] start" << std::endl; }
void onRun() { ++runs; }
void onStop() { std::cout << "[cntr2] stop after " << runs << " runs" << std::endl; }

INDUROP_MODULE(name = "cntr2", description = "counts its periods", author = "indurop", license = "Apache-2.0",
               start = &::onStart, run = &::onRun, stop = &::onStop)
