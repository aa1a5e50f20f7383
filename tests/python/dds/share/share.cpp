// share.cpp -- the module of the DDS sharing tests' set (share.glb): every period it writes the
// exported variables from one counter, so that each value tells the period it was written in.
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include <cstdint>

namespace {
uint32_t n = 0;
}

extern "C" void run() {
    ++n;
    SHARE::count = n;
    SHARE::level = n * 0.5;
    SHARE::small = static_cast<int16_t>(static_cast<int32_t>(n % 1000) - 500);
    SHARE::odd = (n & 1) != 0;
    for (int i = 0; i < 4; ++i) SHARE::vec[i] = static_cast<float>(n % 1000 + i);
}
