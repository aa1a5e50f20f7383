// generator.cpp -- a signal generator: every period writes sixteen waveforms of different shapes
// and frequencies (property `base_hz`, default 1 Hz: wave k runs at base_hz x (1 + k % 4)) into
// SIG::wave, sampled on the period grid (property `period_ns` must match the module's period).
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include <cmath>
#include <cstdint>

namespace {
double base_hz = 1.0;
double dt_s = 1e-3;
uint32_t n = 0;

double shape(int k, double phase) {  // phase in cycles
    const double x = phase - std::floor(phase);
    switch (k / 4) {
    case 0: return std::sin(2 * M_PI * x);
    case 1: return x < 0.5 ? 1.0 : -1.0;
    case 2: return x < 0.5 ? 4 * x - 1 : 3 - 4 * x;
    default: return 0.6 * std::sin(2 * M_PI * x) + 0.4 * std::sin(2 * M_PI * 7 * x);
    }
}
}  // namespace

extern "C" void initialize(irp::Property const &p) {
    base_hz = p.get<double>("base_hz", 1.0);
    dt_s = p.get<double>("period_ns", 1e6) * 1e-9;
    if (!(base_hz > 0) || !(dt_s > 0)) throw irp::PropertyError("base_hz and period_ns must be positive");
}

extern "C" void run() {
    const double t = n * dt_s;
    for (int k = 0; k < 16; ++k) SIG::wave[k] = shape(k, base_hz * (1 + k % 4) * t + 0.0625 * k);
    SIG::sample = ++n;
}
