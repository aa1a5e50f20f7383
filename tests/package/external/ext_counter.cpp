// ext_counter.cpp -- counts its periods in the shared variable ext.count.
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include <cstdio>

void onRun() { ext::count += 1; }
void onStop() { std::printf("[ext_counter] count = %llu\n", static_cast<unsigned long long>(ext::count)); }
INDUROP_MODULE(run = &::onRun, stop = &::onStop)
