// pc_counter.cpp -- the same kind of module, built with pkg-config instead of CMake (and the ST
// runtime's headers found the same way).
#include <indurop/indurop.h>
#include <indurop/st/st.hpp>

#include <cstdio>

static unsigned long runs;
void onRun() { runs = irp::st::ADD(runs, 1); }
void onStop() { std::printf("[pc_counter] runs = %lu\n", runs); }
INDUROP_MODULE(run = &::onRun, stop = &::onStop)
