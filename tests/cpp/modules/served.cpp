// served.cpp -- thread modules whose exported functions process modules call through irpd
// (tests/cpp/test_shared_functions.cpp, the caller is tests/cpp/processes/fn_caller.cpp).  Each
// served call says with irp::printf which function it served and in which cycle, so that the test
// sees in irpd's output that it ran in the owner's slot.
//   FN_OWNER:    "math.scale" double(double), "math.pair" Pair(Pair, int32_t), "math.count"
//                void(int32_t), "math.total" int64_t(), "math.throws" int32_t(int32_t) (throws on a
//                negative input), "math.big" double(Big) (300 bytes of arguments: too large),
//                "math.peek" double(const double *) (a pointer: not callable from a process)
//   FN_SLOW:     "slow.echo" int32_t(int32_t); run it with a long period to make calls time out
//   FN_IDLE:     "idle.get" int32_t(); run it with a period longer than the run: never served
//   FN_FRAGILE:  "fragile.get" int32_t(); run() throws at its `throw_at`-th run (default 20)
//   FN_SPORADIC: "evt.get" int32_t() from a sporadic module (condition() never true)
#include "fn_types.hpp"

#include <indurop/indurop.h>

#include <stdexcept>
#include <string>

namespace {
[[maybe_unused]] unsigned long long cycleNow() { return static_cast<unsigned long long>(irp::cycle().count); }
}  // namespace

#if defined(FN_OWNER)
#ifndef FN_FACTOR
#define FN_FACTOR 2.5  // fn_owner_v2 is built with 3.5: a replaced exporter's new code (test_online_change)
#endif
int64_t total = 0;
double scale(double v) {
    irp::printf("fn_owner: served math.scale(%g) in cycle %llu\n", v, cycleNow());
    return v * FN_FACTOR;
}
fn_types::Pair pair(fn_types::Pair p, int32_t k) {
    irp::printf("fn_owner: served math.pair in cycle %llu\n", cycleNow());
    return {p.a + k, p.b * k};
}
void count(int32_t n) { total += n; }
int64_t getTotal() { return total; }
int32_t throws(int32_t v) {
    if (v < 0) throw std::runtime_error("negative input " + std::to_string(v));
    return v;
}
double big(fn_types::Big b) { return b.bytes[0]; }
double peek(const double *p) { return *p; }
bool onInit() {
    irp::exportFunction("math.scale", &scale);
    irp::exportFunction("math.pair", &pair);
    irp::exportFunction("math.count", &count);
    irp::exportFunction("math.total", &getTotal);
    irp::exportFunction("math.throws", &throws);
    irp::exportFunction("math.big", &big);
    irp::exportFunction("math.peek", &peek);
    return true;
}
void onRun() {}
INDUROP_MODULE(initialize = &::onInit, run = &::onRun)
#elif defined(FN_SLOW)
int32_t echo(int32_t v) {
    irp::printf("fn_slow: served slow.echo(%d) in cycle %llu\n", v, cycleNow());
    return v;
}
void onInit() { irp::exportFunction("slow.echo", &echo); }
void onRun() {}
INDUROP_MODULE(initialize = &::onInit, run = &::onRun)
#elif defined(FN_IDLE)
int32_t get() { return 1; }
void onInit() { irp::exportFunction("idle.get", &get); }
void onRun() {}
INDUROP_MODULE(initialize = &::onInit, run = &::onRun)
#elif defined(FN_FRAGILE)
int64_t throw_at = 20, runs = 0;
int32_t get() { return 7; }
void onInit(irp::Property const &p) {
    throw_at = p.get<int64_t>("throw_at", 20);
    irp::exportFunction("fragile.get", &get);
}
void onRun() {
    if (++runs == throw_at) throw std::runtime_error("fragile gives up");
}
INDUROP_MODULE(initialize = &::onInit, run = &::onRun)
#elif defined(FN_SPORADIC)
int32_t get() { return 3; }
void onInit() { irp::exportFunction("evt.get", &get); }
int onCondition() { return 0; }
void onRun() {}
INDUROP_MODULE(initialize = &::onInit, run = &::onRun, condition = &::onCondition)
#else
#error "served.cpp needs one FN_* definition"
#endif
