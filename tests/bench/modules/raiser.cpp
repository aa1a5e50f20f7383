// raiser.cpp -- the sporadic-reaction benchmark's periodic thread module: every `every`-th basic
// period (property, default 4) it raises the event of shared/sporadic.glb: it reads
// CLOCK_MONOTONIC, stores that time and the basic period's count, then bumps `seq` -- from that
// store on, the sporadic modules' condition is true.
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include "common/bench_hist.hpp"

namespace {
uint64_t g_every = 4;

void onInit(irp::Property const &p) {
    g_every = static_cast<uint64_t>(p.get("every", int64_t{4}));
    if (g_every == 0) g_every = 1;
}

void onRun() {
    const irp::Cycle &c = irp::cycle();
    if (c.count % g_every) return;
    sporadic::raised_cycle = c.count;
    sporadic::raised_ns = bench::nowNs();
    sporadic::seq = sporadic::seq + 1;  // single writer: a load and a release store
}
}  // namespace

INDUROP_MODULE(name = "raiser", description = "benchmark: raises the sporadic event every n-th basic period",
               initialize = &::onInit, run = &::onRun)
