// reactor.cpp -- the sporadic-reaction benchmark's sporadic thread module: condition() is true when
// the event of shared/sporadic.glb was raised since the last run(); run() records its own start
// minus the raise time (the reaction time) and in which basic period it runs relative to the one
// that raised the event (0 = the same).  stop() prints both (bench_hist.hpp's text form).
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include "common/bench_hist.hpp"

#include <cstdio>

namespace {
bench::Histogram g_reaction;
uint64_t g_seen = 0;                           // the last seq handled
uint64_t g_same = 0, g_next = 0, g_later = 0;  // basic period of the reaction vs the raise
uint64_t g_lost = 0;                           // raises never handled (seq moved by more than 1)

void onStart() { g_seen = sporadic::seq; }

int onCondition() { return sporadic::seq != g_seen; }

void onRun() {
    const int64_t start = bench::nowNs();
    const uint64_t seq = sporadic::seq;
    const int64_t raised = sporadic::raised_ns;
    const uint64_t raised_cycle = sporadic::raised_cycle;
    g_reaction.record(start - raised);
    const uint64_t delta = irp::cycle().count - raised_cycle;
    (delta == 0 ? g_same : delta == 1 ? g_next : g_later) += 1;
    if (seq - g_seen > 1) g_lost += seq - g_seen - 1;
    g_seen = seq;
}

void onStop() {
    g_reaction.print(stdout, "sporadic_thread");
    std::printf("@info sporadic_thread same_period=%llu next_period=%llu later=%llu lost=%llu\n",
                static_cast<unsigned long long>(g_same), static_cast<unsigned long long>(g_next),
                static_cast<unsigned long long>(g_later), static_cast<unsigned long long>(g_lost));
    std::fflush(stdout);
}
}  // namespace

INDUROP_MODULE(name = "reactor", description = "benchmark: sporadic thread, measures its reaction time",
               start = &::onStart, run = &::onRun, stop = &::onStop, condition = &::onCondition)
