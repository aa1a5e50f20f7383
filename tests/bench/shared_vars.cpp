// shared_vars.cpp -- cost of shared-variable accesses against plain memory, uncontended:
// a scalar read and write, a 48-byte struct read and write, a member write, `+=`.
// Prints one JSON object (ns per operation, the minimum over several rounds).
#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"

#include <indurop/generated.h>

#include <cstdio>
#include <cstring>
#include <ctime>
#include <string>
#include <unistd.h>

namespace {

struct Pose {
    double a, b, c, d, e, f;
};
static_assert(sizeof(Pose) == 48);

volatile uint64_t plain_scalar;
Pose plain_pose;

int64_t now() {
    timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1'000'000'000LL + ts.tv_nsec;
}

// ns per call of op, the best of 7 rounds of n calls.
template <class Op>
double measure(Op op, int n = 2'000'000) {
    double best = 1e9;
    for (int round = 0; round < 7; ++round) {
        int64_t t = now();
        for (int i = 0; i < n; ++i) op(i);
        best = std::min(best, static_cast<double>(now() - t) / n);
    }
    return best;
}

}  // namespace

int main(int argc, char **argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: shared_vars LAYOUT.json\n");
        return 2;
    }
    auto layout = irp::variables::readLayout(argv[1]);
    if (!layout) return std::fprintf(stderr, "%s\n", layout.error().message.c_str()), 1;
    auto segment = irp::variables::VariableSegment::create("bench-shared-" + std::to_string(getpid()), *layout);
    if (!segment) return std::fprintf(stderr, "%s\n", segment.error().message.c_str()), 1;

    using namespace bench;
    uint64_t sink = 0;
    Pose p{};
    const double plain_read = measure([&](int) { sink += plain_scalar; });
    const double plain_write = measure([&](int i) { plain_scalar = static_cast<uint64_t>(i); });
    // Plain memory: a 48-byte copy the compiler may not drop or merge across iterations.
    const double plain_struct_read = measure([&](int) {
        Pose v;
        asm volatile("" ::: "memory");
        std::memcpy(&v, &plain_pose, sizeof v);
        asm volatile("" ::: "memory");
        sink += static_cast<uint64_t>(v.a);
    });
    const double plain_struct_write = measure([&](int i) {
        p.a = i;
        std::memcpy(&plain_pose, &p, sizeof p);
        asm volatile("" ::: "memory");
    });
    const double scalar_read = measure([&](int) { sink += bench::scalar; });
    const double scalar_write = measure([&](int i) { bench::scalar = static_cast<uint64_t>(i); });
    const double scalar_add = measure([&](int) { bench::scalar += 1; });
    const double struct_read = measure([&](int) {
        pose_t v = pose;
        sink += static_cast<uint64_t>(v.a);
    });
    const double struct_write = measure([&](int i) {
        pose_t v{static_cast<double>(i), 1, 2, 3, 4, 5};
        pose = v;
    });
    const double member_write = measure([&](int i) { pose.a = i; });
    std::printf("{\"plain_scalar_read_ns\": %.2f, \"plain_scalar_write_ns\": %.2f, \"plain_struct48_read_ns\": %.2f, "
                "\"plain_struct48_write_ns\": %.2f, \"scalar_read_ns\": %.2f, \"scalar_write_ns\": %.2f, "
                "\"scalar_add_ns\": %.2f, \"struct48_read_ns\": %.2f, \"struct48_write_ns\": %.2f, "
                "\"member_write_ns\": %.2f, \"sink\": %llu}\n",
                plain_read, plain_write, plain_struct_read, plain_struct_write, scalar_read, scalar_write, scalar_add,
                struct_read, struct_write, member_write, static_cast<unsigned long long>(sink % 10));
    return 0;
}
