// functions.cpp -- shared functions between thread modules (see <indurop/functions.h>).
//   FN_EXPORT:    exports "math.scale" (double(double)) in initialize()
//   FN_IMPORT:    finds it in start(), calls it in run() and journals the result's integer part
//   FN_WRONG_SIG: finds "math.scale" as int(int): start() must fail
//   FN_MISSING:   finds a name nobody exports: start() must fail
#include "journal.hpp"

#include <indurop/indurop.h>

#include <string>

#if defined(FN_EXPORT)
#ifndef FN_FACTOR
#define FN_FACTOR 2.5  // fn_export_v2 is built with 3.5 (test_online_change: an exporter replaced)
#endif
double scale(double v) { return v * FN_FACTOR; }
bool onInit() {
    irp::exportFunction("math.scale", &scale);
    return true;
}
void onRun() {}
INDUROP_MODULE(initialize = &::onInit, run = &::onRun)
#elif defined(FN_IMPORT)
#ifndef FN_IMPORTER
#define FN_IMPORTER "fn_import"  // fn_import_v2 journals as "fn_import_v2": another build of the same code
#endif
double (*scale)(double) = nullptr;
void onStart() { scale = irp::findFunction<double(double)>("math.scale"); }
void onRun() { journal::add(FN_IMPORTER, std::to_string(static_cast<int>(scale(4.0))).c_str(), irp::cycle().count); }
INDUROP_MODULE(start = &::onStart, run = &::onRun)
#elif defined(FN_WRONG_SIG)
void onStart() { irp::findFunction<int(int)>("math.scale"); }
void onRun() {}
INDUROP_MODULE(start = &::onStart, run = &::onRun)
#elif defined(FN_MISSING)
void onStart() { irp::findFunction<void()>("nobody.exports.this"); }
void onRun() {}
INDUROP_MODULE(start = &::onStart, run = &::onRun)
#else
#error "functions.cpp needs one FN_* definition"
#endif
