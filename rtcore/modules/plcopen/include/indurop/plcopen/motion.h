// motion.h -- PLCopen Motion Control style function blocks for one robot (an axis group):
// MC_Power, MC_MoveAbsolute (joint PTP), MC_MoveLinear (Cartesian line), MC_Stop, MC_Reset and
// MC_GroupReadError, on the request/answer protocol of axis_group.h.
//
// Each block is an object that keeps its state between scans.  A program sets the inputs, calls
// the block once per scan with the axis group, and reads the outputs, as in Structured Text:
//     MoveJ.Execute = step == 1;  MoveJ.Position = home;  MoveJ.Velocity = 0.5;
//     MoveJ(robot);
//     if (MoveJ.Done) step = 2;
//
// Output rules (PLCopen Part 1, "general rules"), for every Execute-triggered block:
//   - a rising edge of Execute starts the command; Busy is TRUE from that call until Done, Error
//     or CommandAborted; Active (motion blocks) while the robot has taken the request and runs it;
//   - Done, Error and CommandAborted are exclusive and stay TRUE while Execute stays TRUE; they
//     reset in the first call with Execute FALSE.  If Execute fell while Busy, the command goes on
//     and its outcome is shown for exactly one call;
//   - a rising edge while Busy starts a new command on the same instance; the superseded one
//     gets no Done or CommandAborted;
//   - a command is aborted (CommandAborted) when any later request is written on the group: a
//     newer motion, MC_Stop, a power change or MC_Reset.  So only one block has the group;
//   - while an MC_Stop's Execute is TRUE (and until it is Done), motion commands are refused with
//     Error, ErrorID = error::kGroupStopping.
// Detailed timing tables per block: docs/plc.md.  Real-time safe: no allocation, no system calls.
#pragma once

#include <indurop/plcopen/axis_group.h>

#include <array>
#include <cstdint>

namespace plcopen {

// What Execute-triggered blocks share: edge detection, the command's phase, the outputs.
class ExecuteBlock {
public:
    // Input
    bool Execute = false;
    // Outputs
    bool Done = false;
    bool Busy = false;
    bool CommandAborted = false;
    bool Error = false;
    int32_t ErrorID = 0;

protected:
    enum class Phase : uint8_t { Idle, Issued, Taken, Done, Error, Aborted };

    // Starts a call: clears a shown outcome once Execute is FALSE; true on Execute's rising edge.
    bool begin();
    void issue(AxisGroupRef &group, OpCode op, double speed, double accel, const double *target);
    void fail(int32_t id);
    void succeed() { phase_ = Phase::Done; }
    // Follows the robot's answer to the issued request (the contract's Done / Error / aborted).
    void track(const AxisGroupRef &group);
    // Sets the outputs from the phase.
    void publish();
    bool running() const { return phase_ == Phase::Issued || phase_ == Phase::Taken; }

    Phase phase_ = Phase::Idle;
    uint32_t seq_ = 0;
    int32_t errorId_ = 0;

private:
    bool lastExecute_ = false;
};

// A move: MC_MoveAbsolute (joint PTP) or MC_MoveLinear (Cartesian line).
class MoveCommand : public ExecuteBlock {
public:
    // Inputs, read at the rising edge of Execute
    std::array<double, kAxes> Position{};  // joint angles (rad), or x y z (m) roll pitch yaw (rad)
    double Velocity = 1.0;                 // fraction (0, 1] of the maximum speed
    double Acceleration = 1.0;             // fraction (0, 1] of the maximum acceleration
    // Output: the robot has taken the request and is running it
    bool Active = false;

protected:
    void cycle(AxisGroupRef &group, OpCode op);
};

// Joint point-to-point move to Position (6 joint angles, rad): op-code 3 (MoveJ).
class MC_MoveAbsolute : public MoveCommand {
public:
    void operator()(AxisGroupRef &AxesGroup) { cycle(AxesGroup, OpCode::MoveJ); }
};

// Straight-line Cartesian move of the TCP to Position (x y z m, roll pitch yaw rad, base frame):
// op-code 4 (MoveL).
class MC_MoveLinear : public MoveCommand {
public:
    void operator()(AxisGroupRef &AxesGroup) { cycle(AxesGroup, OpCode::MoveL); }
};

// Decelerates the group to standstill (op-code 5) and holds it in "stopping" while Execute is
// TRUE: motion commands are refused meanwhile.  Aborts the running motion command.
class MC_Stop : public ExecuteBlock {
public:
    void operator()(AxisGroupRef &AxesGroup);
};

// Clears the group's error (op-code 6: eState 4 -> 0 disabled or 1 standstill).  A group not in
// error needs nothing: Done at once, no request sent (so a reset never aborts a running motion).
class MC_Reset : public ExecuteBlock {
public:
    void operator()(AxisGroupRef &AxesGroup);
};

// Powers the group while Enable is TRUE (op-codes 1 and 2).
//   Status: the robot reports Powered (every drive in operation enabled).
//   Valid:  Enable and no error: Status can be relied on.
//   Busy:   a power request is on its way (until the robot answers it).
//   Error, ErrorID: the power-on was refused or timed out, or the power was lost while enabled
//     with the group in error (a drive fault, lost communication).  The error stays while the
//     group is in error; once it is cleared (MC_Reset) and Enable is still TRUE, MC_Power powers
//     the group on again.  Enable FALSE clears Error.
// A rising Enable on a group already powered sends nothing; a falling Enable sends power-off
// (aborting any running motion) unless the group is off already.
class MC_Power {
public:
    bool Enable = false;
    bool Status = false;
    bool Valid = false;
    bool Busy = false;
    bool Error = false;
    int32_t ErrorID = 0;

    void operator()(AxisGroupRef &AxesGroup);

private:
    void issue(AxisGroupRef &group, OpCode op);

    bool lastEnable_ = false;
    bool pending_ = false;  // a request of ours awaits its answer
    uint32_t seq_ = 0;
    bool error_ = false;
    int32_t errorId_ = 0;
    bool wasPowered_ = false;  // Powered was seen while enabled
    bool retry_ = false;       // power on again once the group's error is cleared
};

// The group's error, read continuously while Enable is TRUE (PLCopen Part 4).
//   Valid: Enable and the group is bound;  GroupErrorID: the robot's ErrorID while the group is in
//   error (eState 4 or Error), else 0.  Error/ErrorID: the block's own failure (an unbound group).
class MC_GroupReadError {
public:
    bool Enable = false;
    bool Valid = false;
    bool Busy = false;
    bool Error = false;
    int32_t ErrorID = 0;
    int32_t GroupErrorID = 0;

    void operator()(const AxisGroupRef &AxesGroup);
};

}  // namespace plcopen
