// cntr2.cpp -- Figure 1's cntr2 (100 us, priority 2), written with INDUROP_MODULE as in
// Figure 5: it advances knu.Robot.tick and joints[0] every period.
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include <cstdint>
#include <iostream>

using namespace knu::Robot;

namespace {
uint64_t runs = 0;
}

void onStart() { std::cout << "[cntr2] start" << std::endl; }

void onRun() {
    ++runs;
    tick = tick + 10;
    INDUROP_TYPEDEF(joints)::value_type v = joints[0];
    v.x += 1;
    v.y += 2;
    v.z += 3;
    joints[0] = v;
}

void onStop() { std::cout << "[cntr2] stop after " << runs << " runs, tick = " << tick << std::endl; }

INDUROP_MODULE(name = "cntr2", description = "advances tick and joints[0]", author = "indurop", license = "Apache-2.0",
               start = &::onStart, run = &::onRun, stop = &::onStop)
