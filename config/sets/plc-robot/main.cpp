// main.cpp -- main.so, the PLC of the plc-robot cell in the shape of the paper's Figure 12:
// initialize() takes the properties, start() calls POU_Initialize(), run() calls POU_PROGRAM()
// every period (10 ms, after the I/O dispatcher and Robot.so).
//
// POU_PROGRAM() is one PLC scan: read the inputs (PLC points and the robot's state) into the
// process image, run the rungs of the pick-and-place POU (POUS.h) on it, write the outputs and
// the robot request of this scan back to the shared variables of cell.glb, and keep the alarm of
// the ErrorID the outputs show (module.xml declares the texts; docs/plc.md "Alarms").
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include "POUS.h"

#include <cstdio>
#include <iostream>
#include <optional>

namespace {

pou::Settings settings;
std::optional<pou::PickAndPlace> program;  // the POU instance: its blocks keep their state between scans

// The process image of the robot's service and state blocks; the motion blocks work on it, and
// keep the PLC's own state of the group (which MC_Stop holds it) in groupStatus.
PLC_ROBOT::ROBOT_MODULE_SERVICE_t service{};
PLC_ROBOT::ROBOT_MODULE_STATE_t state{};
plcopen::GroupStatus groupStatus{};
plcopen::AxisGroupRef robot = plcopen::bindAxisGroup(service, state, groupStatus);

pou::Inputs inputs;
pou::Outputs outputs;

// The ErrorIDs module.xml declares: the robot's 1-8, the blocks' 1001-1004 and the program's 1010
// (pou::kPowerRemoved; docs/plc.md), and the alarm that the cell waits for a reset.
constexpr int32_t kCommLost = 8;
constexpr int32_t kWaitsForReset = 1000;
constexpr int32_t kAlarmIds[] = {1, 2, 3, 4, 5, 6, 7, 8, 1000, 1001, 1002, 1003, 1004, pou::kPowerRemoved};
// The alarms raised now (0: none), and whether they are known: after a hot reload of main.so its
// source keeps the alarms the previous instance raised, so the first scan clears the others.
int32_t cause_raised = 0;
bool waiting_raised = false;
bool alarms_known = false;
int32_t last_step = 0;
char alarm_detail[48] = "";

// An alarm shows a condition (ISA-18.2): it is active while the condition holds.
//  - The cause: while PLC_OUT.Error, the alarm of PLC_OUT.ErrorID.  The PLC latches every error
//    until a reset, and so does its alarm -- except ErrorID 8, whose condition the scan can see:
//    alarm 8 is active while an I/O device of IO_STATUS does not answer, and clears when it
//    answers again, though the PLC's error stays latched.
//  - 1000 "waits for a reset": while PLC_OUT.Error and its cause has cleared.
// Only the changes write a record (irp::raiseAlarm is RT-safe and allocates nothing).
void keepAlarms(bool comm_lost) {
    if (outputs.Step != 0)
        last_step = outputs.Step;
    else if (!outputs.Error)
        last_step = 0;  // idle without an error: a later error is not that cycle's
    const int32_t error = outputs.Error ? outputs.ErrorID : 0;
    const int32_t cause = error == kCommLost && !comm_lost ? 0 : error;
    const bool waiting = error != 0 && cause == 0;
    if (!alarms_known) {
        for (int32_t id : kAlarmIds)
            if (id != cause && !(waiting && id == kWaitsForReset)) irp::clearAlarm(static_cast<uint32_t>(id));
        cause_raised = 0;  // raised again below, with this instance's detail
        waiting_raised = false;
        alarms_known = true;
    }
    if (cause != cause_raised) {
        if (cause_raised > 0) irp::clearAlarm(static_cast<uint32_t>(cause_raised));
        if (cause > 0) {
            std::snprintf(alarm_detail, sizeof alarm_detail, "PLC stopped in step %d of the cycle",
                          static_cast<int>(last_step));
            irp::raiseAlarm(static_cast<uint32_t>(cause), last_step ? alarm_detail : nullptr, cause);
        }
        cause_raised = cause;
    }
    if (waiting != waiting_raised) {
        if (waiting)
            irp::raiseAlarm(static_cast<uint32_t>(kWaitsForReset), nullptr, error);  // value: the ErrorID
        else
            irp::clearAlarm(static_cast<uint32_t>(kWaitsForReset));
        waiting_raised = waiting;
    }
}

void printVector(const char *name, const std::array<double, plcopen::kAxes> &v) {
    std::cout << "  " << name << " =";
    for (double x : v) std::cout << ' ' << x;
    std::cout << '\n';
}

}  // namespace

void POU_Initialize() {
    program.emplace(settings);
    // The panel's defaults, for a fresh (zeroed) segment.
    if (PLC_ROBOT::PLC_IN.Override == 0.0) PLC_ROBOT::PLC_IN.Override = settings.override_default;
    if (settings.auto_enable) PLC_ROBOT::PLC_IN.Enable = 1;
}

void POU_PROGRAM() {
    // ---- read inputs: one consistent copy of each shared variable the scan reads
    const PLC_ROBOT::PLC_IN_t panel = PLC_ROBOT::PLC_IN;
    inputs.I0 = PLC_ROBOT::I0 != 0;
    inputs.I1 = PLC_ROBOT::I1 != 0;
    inputs.Start = panel.Start != 0;
    inputs.Stop = panel.Stop != 0;
    inputs.Reset = panel.Reset != 0;
    inputs.Enable = panel.Enable != 0;
    inputs.CycleMode = panel.CycleMode;
    inputs.Override = panel.Override;
    state = PLC_ROBOT::ROBOT_MODULE_STATE;
    service = PLC_ROBOT::ROBOT_MODULE_SERVICE;
    const uint32_t requested = service.nSeq;
    const PLC_ROBOT::IO_STATUS_t io = PLC_ROBOT::IO_STATUS;  // one consistent copy
    bool comm_lost = false;
    for (short lost : io.comm_lost) comm_lost = comm_lost || lost != 0;
    inputs.DrivesReachable = !comm_lost;

    // ---- the rungs
    program->scan(inputs, outputs, robot, plcopen::Time(irp::cycle().planned_ns));

    // ---- write outputs
    if (service.nSeq != requested) PLC_ROBOT::ROBOT_MODULE_SERVICE = service;  // the request, whole: nSeq with its data
    PLC_ROBOT::O0 = outputs.O0 ? 1 : 0;
    PLC_ROBOT::PLC_OUT_t out{};
    out.Running = outputs.Running;
    out.Done = outputs.Done;
    out.Error = outputs.Error;
    out.Powered = outputs.Powered;
    out.WaitingForDrives = outputs.WaitingForDrives;
    out.Step = outputs.Step;
    out.ErrorID = outputs.ErrorID;
    out.Cycles = outputs.Cycles;
    PLC_ROBOT::PLC_OUT = out;
    keepAlarms(comm_lost);
}

extern "C" void initialize(irp::Property const &property) {
    settings = pou::Settings::fromProperties(property);  // irp::PropertyError refuses the module
    std::cout << "[PLC] pick and place: joint_speed " << settings.joint_speed << ", linear_speed "
              << settings.linear_speed << ", accel " << settings.accel << ", lift " << settings.lift << " m, dwell "
              << settings.dwell.count() / 1'000'000 << " ms\n";
    printVector("home", settings.home);
    printVector("pick_above", settings.pick_above);
    printVector("pick", settings.pick);
    printVector("place_above", settings.place_above);
    printVector("place", settings.place);
    std::cout << std::flush;
}

void start() { POU_Initialize(); }

void run() {
    POU_PROGRAM();  // call the ladder program
}

void stop() { std::cout << "[PLC] stop after " << (program ? program->cycles : 0) << " cycles" << std::endl; }
