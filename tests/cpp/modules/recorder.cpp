// recorder.cpp -- a well-behaved module that journals every lifecycle call and every run with
// its cycle.  Built once per name (RECORDER_NAME), in the plain style (Figure 12) unless
// RECORDER_DESCRIPTOR is set (INDUROP_MODULE, Figures 4 and 5).
#include "journal.hpp"

#include <indurop/indurop.h>

#include <thread>

namespace {
int64_t busy_ns = 0;  // property "busy_ns": spin this long in run(), to make overruns

void spin() {
    if (busy_ns <= 0) return;
    timespec a{}, b{};
    clock_gettime(CLOCK_MONOTONIC, &a);
    do clock_gettime(CLOCK_MONOTONIC, &b);
    while ((b.tv_sec - a.tv_sec) * 1'000'000'000 + (b.tv_nsec - a.tv_nsec) < busy_ns);
}
}  // namespace

#ifdef RECORDER_DESCRIPTOR
bool onInitialize(irp::Property const &p) {
    busy_ns = p.get<int64_t>("busy_ns", 0);
    journal::add(RECORDER_NAME, "initialize");
    return true;
}
void onStart() { journal::add(RECORDER_NAME, "start"); }
void onRun() {
    journal::add(RECORDER_NAME, "run", irp::cycle().count);
    spin();
}
void onStop() { journal::add(RECORDER_NAME, "stop"); }
INDUROP_MODULE(name = RECORDER_NAME, description = "journals its calls", initialize = &::onInitialize,
               start = &::onStart, run = &::onRun, stop = &::onStop)
#else
extern "C" void initialize(irp::Property const &p) {
    busy_ns = p.get<int64_t>("busy_ns", 0);
    journal::add(RECORDER_NAME, "initialize");
}
void start() { journal::add(RECORDER_NAME, "start"); }
void run() {
    journal::add(RECORDER_NAME, "run", irp::cycle().count);
    spin();
}
void stop() { journal::add(RECORDER_NAME, "stop"); }
#endif
