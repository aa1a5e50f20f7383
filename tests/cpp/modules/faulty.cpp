// faulty.cpp -- modules that fail on purpose, one per FAULT_* definition, each loaded through
// the production loader by test_thread_module to check that irpd refuses or contains it.
#include "journal.hpp"

#include <indurop/indurop.h>

#include <stdexcept>

#if defined(FAULT_NO_RUN_PLAIN)
// Plain style with start() but no run().
void start() {}

#elif defined(FAULT_NO_RUN_DESCRIPTOR)
void onStart() {}
INDUROP_MODULE(name = "no_run", start = &::onStart)

#elif defined(FAULT_UNRESOLVED)
extern "C" void indurop_fixture_symbol_that_does_not_exist();
void run() { indurop_fixture_symbol_that_does_not_exist(); }

#elif defined(FAULT_INIT_THROWS)
extern "C" void initialize(irp::Property const &) { throw std::runtime_error("calibration table missing"); }
void run() {}

#elif defined(FAULT_INIT_FALSE)
bool onInit() { return false; }
void onRun() {}
INDUROP_MODULE(initialize = &::onInit, run = &::onRun)

#elif defined(FAULT_BAD_PROPERTY)
int gain = 0;
bool onInit(irp::Property const &p) {
    gain = p.get<int>("gain", 1);
    return true;
}
void onRun() {}
INDUROP_MODULE(initialize = &::onInit, run = &::onRun)

#elif defined(FAULT_START_THROWS)
void onStart() { throw std::runtime_error("drive not ready"); }
void onRun() {}
void onStop() { journal::add("start_throws", "stop"); }
INDUROP_MODULE(start = &::onStart, run = &::onRun, stop = &::onStop)

#elif defined(FAULT_THROWS_IN_RUN)
int runs = 0;
void onRun() {
    journal::add("throws_in_run", "run", irp::cycle().count);
    if (++runs == 3) throw std::runtime_error("division by zero in the controller");
}
INDUROP_MODULE(run = &::onRun)

#elif defined(FAULT_ABI_MISMATCH)
// A descriptor from a future SDK.
namespace {
void onRun() {}
indurop_module_v1 table = {
    99, sizeof(indurop_module_v1), "future", nullptr, nullptr, nullptr, nullptr, nullptr, &onRun, nullptr, nullptr};
}  // namespace
extern "C" __attribute__((visibility("default"))) const indurop_module_v1 *indurop_module_v1_descriptor(void) {
    return &table;
}

#else
#error "faulty.cpp needs one FAULT_* definition"
#endif
