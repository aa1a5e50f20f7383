// cntr1.cpp -- Figure 1's cntr1 (500 us, priority 3), in the plain style of Figure 12:
// extern "C" initialize(irp::Property const&) reads the set's property; run() counts in the
// shared variable knu.Robot.joints[1] (Figure 3).
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include <cstdint>
#include <iostream>

namespace {
int64_t counter = 0;
uint64_t runs = 0;
}  // namespace

extern "C" void initialize(irp::Property const &property) {
    counter = property.get<int64_t>("intialize_value", 0);  // the paper's spelling
    std::cout << "[cntr1] initialize: counter starts at " << counter << std::endl;
}

void start() { std::cout << "[cntr1] start" << std::endl; }

void run() {
    ++counter;
    ++runs;
    knu::Robot::joints[1].x = static_cast<double>(counter);
}

void stop() { std::cout << "[cntr1] stop after " << runs << " runs, counter = " << counter << std::endl; }
