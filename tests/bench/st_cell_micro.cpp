// st_cell_micro.cpp -- the plc-robot cell's PLC module alone, its run() timed period by period: a
// quick figure for comparing the C++ PLC (config/sets/plc-robot's main.so) with the ST one (stc's
// main.so of config/sets/plc-robot-st) while changing the ST compiler, without irpd's dispatcher or
// other modules.  The module is loaded by the production loader from its set's module.xml on a real
// segment of the set's layout.json; before each run the simulated robot of the PLC tests
// (tests/cpp/support/fake_robot.hpp) answers the request, as Robot.so would; the operator panel
// enables, starts CycleMode 1 and the cell cycles.  irp::cycle() advances by the period, so timers
// run.  Between two runs the program writes a buffer of `evict_kb` KiB (default 4096: the L2 caches),
// as the rest of a 10 ms period does in irpd, so that run() starts with cold L1/L2 caches as there
// (0: hot caches).  st_bench.py's cell figures (irpd, both cells' modules) remain the benchmark.
//
//   st_cell_micro SET/module.xml [periods] [rounds] [evict_kb]   -> mean and median run() ns of `main`
#include "config/module_xml.hpp"
#include "hosts/thread_module.hpp"
#include "sdk/runtime.hpp"
#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"

#include "fake_robot.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

namespace {

int64_t now() {
    timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1'000'000'000LL + ts.tv_nsec;
}

int fail(const std::string &what) {
    std::fprintf(stderr, "st_cell_micro: %s\n", what.c_str());
    return 1;
}

}  // namespace

int main(int argc, char **argv) {
    if (argc < 2) return fail("usage: st_cell_micro SET/module.xml [periods] [rounds] [evict_kb]");
    const long periods = argc > 2 ? std::atol(argv[2]) : 20000;
    const int rounds = argc > 3 ? std::atoi(argv[3]) : 5;
    std::vector<char> evict(static_cast<std::size_t>(argc > 4 ? std::atol(argv[4]) : 4096) * 1024);
    auto set = irp::config::parseModuleXml(argv[1]);
    if (!set.ok()) return fail(set.error().message);
    const auto spec = std::find_if(set->modules.begin(), set->modules.end(), [](auto &m) { return m.name == "main"; });
    if (spec == set->modules.end()) return fail("no module `main` in the set");
    const auto layout_path = set->layout.empty() ? spec->path.parent_path() / "layout.json" : set->layout;
    auto layout = irp::variables::readLayout(layout_path);
    if (!layout.ok()) return fail(layout.error().message);
    auto segment = irp::variables::VariableSegment::create("st-cell-micro-" + std::to_string(getpid()), *layout);
    if (!segment.ok()) return fail(segment.error().message);
    auto module = irp::hosts::ThreadModule::load(*spec, irp::shared::layoutHash().c_str());
    if (!module.ok()) return fail(module.error().message);
    if (auto s = (*module)->initialize(); !s.ok()) return fail(s.error().message);
    if (auto s = (*module)->start(); !s.ok()) return fail(s.error().message);
    auto run = (*module)->runFunction();

    plc_test::FakeRobot robot;
    irp::Cycle cycle{0, 0, 1'000'000'000LL, spec->period_ns};
    std::vector<int64_t> took;
    took.reserve(static_cast<std::size_t>(periods));
    for (int round = 0; round < rounds; ++round) {
        took.clear();
        for (long k = 0; k < periods; ++k) {
            if (k == 2) PLC_ROBOT::PLC_IN.Enable = 1;
            if (k == 3) PLC_ROBOT::PLC_IN.CycleMode = 1;
            if (k == 20) PLC_ROBOT::PLC_IN.Start = 1;
            if (k == 21) PLC_ROBOT::PLC_IN.Start = 0;
            robot.svc = PLC_ROBOT::ROBOT_MODULE_SERVICE;  // Robot.so, before the PLC
            robot.run();
            PLC_ROBOT::ROBOT_MODULE_STATE = robot.st;
            ++cycle.count;
            cycle.planned_ns += cycle.basic_ns;
            irp::runtime::setCycle(cycle);
            for (std::size_t i = 0; i < evict.size(); i += 64) evict[i] = static_cast<char>(evict[i] + 1);
            const int64_t t0 = now();
            run();
            took.push_back(now() - t0);
        }
        PLC_ROBOT::PLC_IN.Stop = 1;  // the next round starts from idle
        for (int k = 0; k < 50; ++k) {
            robot.svc = PLC_ROBOT::ROBOT_MODULE_SERVICE;
            robot.run();
            PLC_ROBOT::ROBOT_MODULE_STATE = robot.st;
            run();
        }
        PLC_ROBOT::PLC_IN.Stop = 0;
        int64_t sum = 0;
        for (int64_t t : took) sum += t;
        std::nth_element(took.begin(), took.begin() + took.size() / 2, took.end());
        std::printf("round %d: %ld runs, mean %.0f ns, p50 %lld ns, cycles %u\n", round, periods,
                    static_cast<double>(sum) / static_cast<double>(periods),
                    static_cast<long long>(took[took.size() / 2]), PLC_ROBOT::PLC_OUT.Cycles.load());
    }
    return 0;
}
