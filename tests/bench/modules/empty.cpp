// empty.cpp -- the benchmark's thread module: run() does nothing, so that what irpd measures is
// its own wake-up and dispatch, not a module's work.  One .so, listed many times under distinct
// <name>s, makes the 100-module set of the dispatch-overhead run.
#include <indurop/indurop.h>

void onRun() {}

INDUROP_MODULE(name = "empty", description = "benchmark: does nothing", run = &::onRun)
