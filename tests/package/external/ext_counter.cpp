// ext_counter.cpp -- counts its periods in the shared variable ext.count, with the installed ST
// runtime's wrapping ADD (the headers come with indurop::indurop).
#include <indurop/indurop.h>
#include <indurop/generated.h>
#include <indurop/st/st.hpp>

#include <cstdio>

void onRun() { ext::count = irp::st::ADD(ext::count.load(), 1); }
void onStop() { std::printf("[ext_counter] count = %llu\n", static_cast<unsigned long long>(ext::count)); }
INDUROP_MODULE(run = &::onRun, stop = &::onStop)
