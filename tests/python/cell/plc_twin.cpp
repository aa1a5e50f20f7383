// plc_twin.cpp -- the rest of the plc-robot cell for test_plc_robot_st.py, as one thread module that
// runs before the PLC in every period (priority 2, where Robot.so runs): it records what the PLC wrote
// in the previous period (PLC_OUT, O0, the robot request ROBOT_MODULE_SERVICE), then sets this
// period's operator panel (PLC_IN, I0, I1) and the drives' IO_STATUS from a fixed script, and steps
// the simulated robot of the PLC tests (tests/cpp/support/fake_robot.hpp) on the request.  Everything
// is a function of the number of the run, so two cells given the same script see the same inputs in
// the same period; after `periods` runs it writes the record to the file `trace` (one line a period).
#include <indurop/generated.h>
#include <indurop/indurop.h>

#include "fake_robot.hpp"

#include <cstdio>
#include <limits>
#include <string>
#include <vector>

namespace {

std::string tracePath;
long periods = 0;
long k = 0;  // runs so far
std::vector<std::string> lines;
plc_test::FakeRobot robot;

void record() {
    const PLC_ROBOT::PLC_OUT_t out = PLC_ROBOT::PLC_OUT;
    const PLC_ROBOT::ROBOT_MODULE_SERVICE_t svc = PLC_ROBOT::ROBOT_MODULE_SERVICE;
    char line[512];
    int n = std::snprintf(line, sizeof line,
                          "%ld out Running=%d Done=%d Error=%d Powered=%d WaitingForDrives=%d Step=%d ErrorID=%d "
                          "Cycles=%u O0=%d | request eOpCode=%d nSeq=%u t_speed=%.17g t_accel=%.17g dTarget=",
                          k, out.Running, out.Done, out.Error, out.Powered, out.WaitingForDrives, out.Step, out.ErrorID,
                          out.Cycles, static_cast<int>(PLC_ROBOT::O0), svc.eOpCode, svc.nSeq, svc.t_speed, svc.t_accel);
    for (double x : svc.dTarget) n += std::snprintf(line + n, sizeof line - n, "%.17g ", x);
    lines.emplace_back(line, n);
}

void commLost(short lost) {
    PLC_ROBOT::IO_STATUS_t io = PLC_ROBOT::IO_STATUS;
    io.comm_lost[0] = lost;
    PLC_ROBOT::IO_STATUS = io;
}

// The operator's and the plant's script: period -> what changes.
void script() {
    auto pulse = [](auto &&set, long at) {
        if (k == at) set(1);
        if (k == at + 1) set(0);
    };
    auto start = [](short v) { PLC_ROBOT::PLC_IN.Start = v; };
    auto reset = [](short v) { PLC_ROBOT::PLC_IN.Reset = v; };
    if (k == 5) PLC_ROBOT::PLC_IN.Enable = 1;
    pulse([](short v) { PLC_ROBOT::I0 = v; }, 40);  // one cycle from I0
    if (k == 300) {                                 // CycleMode 1 at half speed: cycles until Stop
        PLC_ROBOT::PLC_IN.Override = 0.5;
        PLC_ROBOT::PLC_IN.CycleMode = 1;
    }
    pulse(start, 301);
    if (k == 520) PLC_ROBOT::PLC_IN.Override = 2.0;                                       // clamped to 1
    if (k == 600) PLC_ROBOT::PLC_IN.Override = std::numeric_limits<double>::quiet_NaN();  // the minimum
    if (k == 640) PLC_ROBOT::PLC_IN.Override = 1.0;
    if (k == 800) PLC_ROBOT::I1 = 1;  // Stop, a level
    if (k == 830) PLC_ROBOT::I1 = 0;
    if (k == 831) PLC_ROBOT::PLC_IN.CycleMode = 0;
    pulse(start, 850);
    if (k == 900) robot.driveFault(4);  // the robot's own error: ErrorID 4 until a reset
    pulse(start, 920);                  // refused while in error
    pulse(reset, 950);
    pulse(start, 1000);
    if (k == 1060) PLC_ROBOT::PLC_IN.Enable = 0;  // power removed while the cycle runs: ErrorID 1010
    if (k == 1100) PLC_ROBOT::PLC_IN.Enable = 1;
    pulse(reset, 1150);
    if (k == 1200) {  // the drives stop answering: the robot faults with 8, Enable waits for them
        commLost(1);
        robot.driveFault(8);
        PLC_ROBOT::PLC_IN.Enable = 0;
    }
    if (k == 1220) PLC_ROBOT::PLC_IN.Enable = 1;
    if (k == 1260) commLost(0);  // answering again: alarm 1000 says the cell waits for a reset
    pulse(reset, 1300);
    pulse(start, 1350);
}

}  // namespace

extern "C" void initialize(irp::Property const &property) {
    tracePath = property.get("trace");
    periods = property.get<long>("periods", 1500);
    lines.reserve(periods + 1);
}

void run() {
    if (k > periods) return;
    if (k > 0) record();  // what the PLC wrote in period k - 1
    if (k == periods) {
        if (std::FILE *f = std::fopen(tracePath.c_str(), "w")) {
            for (const auto &l : lines) std::fprintf(f, "%s\n", l.c_str());
            std::fclose(f);
        }
        ++k;
        return;
    }
    script();
    robot.svc = PLC_ROBOT::ROBOT_MODULE_SERVICE;  // as Robot.so: take the request, answer in the state
    robot.run();
    PLC_ROBOT::ROBOT_MODULE_STATE = robot.st;
    ++k;
}
