// pc_counter.cpp -- the same kind of module, built with pkg-config instead of CMake.
#include <indurop/indurop.h>

#include <cstdio>

static unsigned long runs;
void onRun() { ++runs; }
void onStop() { std::printf("[pc_counter] runs = %lu\n", runs); }
INDUROP_MODULE(run = &::onRun, stop = &::onStop)
