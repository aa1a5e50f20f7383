// fn_caller.cpp -- a process module that calls shared functions of thread modules through irpd
// (modules/served.cpp exports them) and prints one line per call:
//   step <name> rc=<rc> status=<lastCallStatus> value=<what it got> ms=<how long it took> error=<lastCallError>
// Without options (run it as a non-real module) it goes through every case of the contract, then
// prints "done" and exits.  With --sporadic (a sporadic module) it makes one call in its first
// release and says in which cycle it was released.
#include "fn_types.hpp"

#include <indurop/indurop.h>

#include <cstdio>
#include <cstring>
#include <ctime>
#include <string>
#include <typeinfo>

namespace {

constexpr int64_t kMs = 1'000'000;

int64_t nowNs() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1'000'000'000LL + ts.tv_nsec;
}

void report(const char *step, int rc, const std::string &value, int64_t started) {
    std::printf("step %s rc=%d status=%d value=%s ms=%lld error=%s\n", step, rc, irp::lastCallStatus(), value.c_str(),
                static_cast<long long>((nowNs() - started) / kMs), irp::lastCallError());
    std::fflush(stdout);
}

template <class F>
void step(const char *name, F &&call) {
    const int64_t started = nowNs();
    std::string value = "-";
    const int rc = call(value);
    report(name, rc, value, started);
}

int sporadic() {
    if (irp::initPeriodExe() != 0) return 2;
    irp::SharedFunction<double(double)> scale("math.scale");
    bool called = false;
    while (irp::waitPeriod() == 0) {
        if (called) continue;
        called = true;
        const unsigned long long released = irp::cycle().count;
        double y = 0;
        const int64_t started = nowNs();
        const int rc = scale(&y, 500 * kMs, 2.0);
        char value[64];
        std::snprintf(value, sizeof value, "%g released=%llu", y, released);
        report("sporadic", rc, value, started);
    }
    return 0;
}

}  // namespace

// --loop: calls math.scale(4.0) every 20 ms and prints "scale=<value>" (test_online_change: the
// owner replaced online, the calls go on to its new code).
int loop() {
    irp::SharedFunction<double(double)> scale("math.scale");
    for (int i = 0; i < 100000; ++i) {
        double y = 0;
        if (scale(&y, 2'000 * kMs, 4.0) == 0)
            std::printf("scale=%g\n", y);
        else
            std::printf("scale failed: %s\n", irp::lastCallError());
        std::fflush(stdout);
        timespec pause{0, 20 * kMs};
        nanosleep(&pause, nullptr);
    }
    return 0;
}

int main(int argc, char *argv[]) {
    if (argc > 1 && std::strcmp(argv[1], "--sporadic") == 0) return sporadic();
    if (argc > 1 && std::strcmp(argv[1], "--loop") == 0) return loop();

    using fn_types::Big;
    using fn_types::Pair;
    irp::SharedFunction<double(double)> scale("math.scale");

    step("scale", [&](std::string &v) {
        double y = 0;
        const int rc = scale(&y, 2'000 * kMs, 4.0);
        v = std::to_string(y);
        return rc;
    });
    step("scale_deduced", [&](std::string &v) {
        double y = 0;
        const int rc = irp::callFunction("math.scale", &y, 2'000 * kMs, 1.5);
        v = std::to_string(y);
        return rc;
    });
    step("pair", [&](std::string &v) {
        Pair out{};
        const int rc = irp::SharedFunction<Pair(Pair, int32_t)>("math.pair")(&out, 2'000 * kMs, Pair{3, 0.5}, 4);
        v = "a=" + std::to_string(out.a) + ",b=" + std::to_string(out.b);
        return rc;
    });
    step("count", [&](std::string &v) {
        int rc = irp::callFunction("math.count", nullptr, 2'000 * kMs, int32_t{5});
        if (rc == 0) rc = irp::callFunction("math.count", nullptr, 2'000 * kMs, int32_t{5});
        int64_t total = -1;
        if (rc == 0) rc = irp::SharedFunction<int64_t()>("math.total")(&total, 2'000 * kMs);
        v = std::to_string(total);
        return rc;
    });
    step("fragile", [&](std::string &v) {
        // Served every period until its owner throws from run() and is disabled.
        irp::SharedFunction<int32_t()> get("fragile.get");
        int ok = 0, rc = 0;
        for (int i = 0; i < 5000 && rc == 0; ++i) {
            int32_t x = 0;
            rc = get(&x, 500 * kMs);
            if (rc == 0 && x == 7) ++ok;
        }
        v = "ok=" + std::to_string(ok);
        return rc;
    });
    step("unknown", [&](std::string &) {
        double y = 0;
        return irp::callFunction("math.nope", &y, 2'000 * kMs, 1.0);
    });
    step("wrong_signature", [&](std::string &) {
        int32_t y = 0;
        return irp::SharedFunction<int32_t(int32_t)>("math.scale")(&y, 2'000 * kMs, 4);
    });
    step("wrong_signature_deduced", [&](std::string &) {
        double y = 0;
        return irp::callFunction("math.scale", &y, 2'000 * kMs, 4);  // 4 is an int: double(int)
    });
    step("too_large", [&](std::string &) {
        double y = 0;
        Big big{};
        return irp::SharedFunction<double(Big)>("math.big")(&y, 2'000 * kMs, big);
    });
    step("pointer", [&](std::string &) {
        // A process cannot even declare SharedFunction<double(const double *)> (static_assert); the
        // table refuses it too, for a caller that names the signature by hand.
        uint32_t index = 0;
        return irp::detail::resolveFunction("math.peek", typeid(double(const double *)).name(), sizeof(double *),
                                            sizeof(double), &index);
    });
    step("throws", [&](std::string &) {
        int32_t y = 0;
        return irp::SharedFunction<int32_t(int32_t)>("math.throws")(&y, 2'000 * kMs, -3);
    });
    step("sporadic_owner", [&](std::string &) {
        int32_t y = 0;
        return irp::SharedFunction<int32_t()>("evt.get")(&y, 2'000 * kMs);
    });
    step("bad_timeout", [&](std::string &) {
        double y = 0;
        return scale(&y, 0, 1.0);
    });

    // A 500 ms owner: the first call waits for its next period; the second, made right after an
    // answer, cannot be served within 5 ms; the third shows the withdrawn request left no trace.
    irp::SharedFunction<int32_t(int32_t)> echo("slow.echo");
    for (int32_t k = 1; k <= 3; ++k) {
        const std::string name = "echo" + std::to_string(k);
        step(name.c_str(), [&](std::string &v) {
            int32_t y = 0;
            const int rc = echo(&y, k == 2 ? 5 * kMs : 3'000 * kMs, k);
            v = std::to_string(y);
            return rc;
        });
    }
    // An owner whose next period comes after irpd stops: the call ends when irpd stops serving.
    step("stopped", [&](std::string &) {
        int32_t y = 0;
        return irp::SharedFunction<int32_t()>("idle.get")(&y, 30'000 * kMs);
    });
    std::printf("done\n");
    return 0;
}
