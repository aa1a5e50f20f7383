// rec_source.cpp -- the recorder benchmark's source (tests/bench/recorder_bench.py): every basic
// period it writes rec::row (its count) and 63 doubles that all change every period, so that every
// channel of every row is a new value, as a busy cell's would be.
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include <cmath>
#include <cstdint>

namespace {
uint64_t g_row = 0;
}  // namespace

extern "C" void run() {
    ++g_row;
    for (int k = 0; k < 63; ++k) rec::ch[k] = std::sin(0.001 * static_cast<double>(g_row) * (k + 1));
    rec::row = g_row;
}
