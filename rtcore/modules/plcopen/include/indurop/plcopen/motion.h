// motion.h -- PLCopen Motion Control function blocks for one robot (an axis group of 6 joints):
// MC_Power, MC_Home, MC_MoveAbsolute (joint PTP), MC_MoveRelative, MC_MoveLinear (Cartesian line),
// MC_MoveVelocity (joint velocity), MC_Stop, MC_Reset, MC_ReadActualPosition, MC_ReadStatus,
// MC_ReadAxisError and MC_GroupReadError, on the request/answer protocol of axis_group.h.
//
// Each block is an object that keeps its state between scans.  A program sets the inputs, calls
// the block once per scan with the axis group, and reads the outputs, as in Structured Text:
//     MoveJ.Execute = step == 1;  MoveJ.Position = home;  MoveJ.Velocity = 0.5;
//     MoveJ(robot);
//     if (MoveJ.Done) step = 2;
//
// Every block is a plain value (trivially copyable, standard layout: checked below): its PLCopen
// inputs, then its outputs, in the order of the standard, then its memory (`Internal`, the FB's
// VAR: not an interface, but public as a PLC shows an FB's variables).  A block holds no pointer:
// the group is passed at each call, so an instance may live in shared memory and be copied in and
// out around a scan (docs/st.md).
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
// Enable-triggered blocks (MC_Power, the Read blocks) act while Enable is TRUE; the Read blocks'
// Valid is Enable on a bound group, Busy is FALSE (a read is complete in its call).
// Detailed timing tables per block: docs/plc.md.  Real-time safe: no allocation, no system calls.
#pragma once

#include <indurop/plcopen/axis_group.h>

#include <array>
#include <cstdint>
#include <type_traits>

namespace plcopen {

using Axes = std::array<double, kAxes>;

// The memory of an Execute-triggered command: edge detection, the command's phase, its request.
struct Command {
    enum class Phase : uint8_t { Idle, Issued, Taken, Done, Error, Aborted };
    Phase phase = Phase::Idle;
    bool lastExecute = false;
    uint32_t seq = 0;     // the request written by the command
    int32_t errorId = 0;  // the outcome's ErrorID

    // Starts a call: clears a shown outcome once Execute is FALSE; true on Execute's rising edge.
    bool begin(bool execute);
    void issue(AxisGroupRef &group, OpCode op, double speed, double accel, const double *target);
    void fail(int32_t id);
    void succeed() { phase = Phase::Done; }
    // Follows the robot's answer to the issued request (the contract's Done / Error / aborted).
    void track(const AxisGroupRef &group);
    bool running() const { return phase == Phase::Issued || phase == Phase::Taken; }
    bool taken() const { return phase == Phase::Taken; }

    // Sets a block's Busy, CommandAborted, Error, ErrorID, and Done if it has one, from the phase.
    template <class Block>
    void publish(Block &b) const {
        b.Busy = running();
        if constexpr (requires { b.Done; }) b.Done = phase == Phase::Done;
        b.Error = phase == Phase::Error;
        b.CommandAborted = phase == Phase::Aborted;
        b.ErrorID = b.Error ? errorId : 0;
    }
};

// The members of a move to a position: MC_MoveAbsolute, MC_MoveLinear and MC_Home.
struct PositionMove {
    // Inputs, read at the rising edge of Execute
    bool Execute = false;
    Axes Position{};            // joint angles (rad), or x y z (m) roll pitch yaw (rad)
    double Velocity = 1.0;      // fraction (0, 1] of the maximum speed
    double Acceleration = 1.0;  // fraction (0, 1] of the maximum acceleration
    // Outputs
    bool Done = false;
    bool Busy = false;
    bool Active = false;  // the robot has taken the request and is running it
    bool CommandAborted = false;
    bool Error = false;
    int32_t ErrorID = 0;
    // Memory
    Command Internal;
};

// Joint point-to-point move to Position (6 joint angles, rad): op-code 3 (MoveJ).
struct MC_MoveAbsolute : PositionMove {
    void operator()(AxisGroupRef &AxesGroup);
};

// Straight-line Cartesian move of the TCP to Position (x y z m, roll pitch yaw rad, base frame):
// op-code 4 (MoveL).
struct MC_MoveLinear : PositionMove {
    void operator()(AxisGroupRef &AxesGroup);
};

// Homing: a joint PTP (op-code 3) to Position, the home position (default: every joint at 0).
// The robot's encoders are absolute, so homing is a move to the reference pose: once Done, the
// group is homed (MC_ReadStatus.IsHomed) until it is seen unpowered.  While the request runs the
// group reads as Homing.  Velocity and Acceleration are this library's additions (PLCopen takes
// them from the axis' configuration, which this robot does not have on the PLC side).
struct MC_Home : PositionMove {
    void operator()(AxisGroupRef &AxesGroup);
};

// Joint PTP (op-code 3) by Distance from the commanded joint angles (ROBOT_MODULE_STATE.dCmdJoint)
// at the rising edge.
struct MC_MoveRelative {
    // Inputs, read at the rising edge of Execute
    bool Execute = false;
    Axes Distance{};            // per joint, rad
    double Velocity = 1.0;      // fraction (0, 1] of the maximum speed
    double Acceleration = 1.0;  // fraction (0, 1] of the maximum acceleration
    // Outputs
    bool Done = false;
    bool Busy = false;
    bool Active = false;
    bool CommandAborted = false;
    bool Error = false;
    int32_t ErrorID = 0;
    // Memory
    Command Internal;

    void operator()(AxisGroupRef &AxesGroup);
};

// Joint velocity motion (op-code 7): every joint at Velocity[i] x its velocity limit, the sign the
// direction, all on one straight line in joint space, until a later command (MC_Stop, a move, a
// power-off) takes over: CommandAborted.  InVelocity while the robot holds the commanded velocity.
// The robot brakes in time to stop a joint at its limit and then reports ErrorID 2 (outside
// limits): Error.  A robot that ends the motion on its own (Robot.so reloaded) gives ErrorID 1005.
// PLCopen's scalar Velocity and Direction become one signed fraction per joint.
struct MC_MoveVelocity {
    // Inputs, read at the rising edge of Execute
    bool Execute = false;
    Axes Velocity{};            // per joint, signed fraction [-1, 1] of its velocity limit; not all 0
    double Acceleration = 1.0;  // fraction (0, 1] of the maximum acceleration
    // Outputs
    bool InVelocity = false;
    bool Busy = false;
    bool Active = false;
    bool CommandAborted = false;
    bool Error = false;
    int32_t ErrorID = 0;
    // Memory
    Command Internal;

    void operator()(AxisGroupRef &AxesGroup);
};

// Decelerates the group to standstill (op-code 5) and holds it in "stopping" while Execute is
// TRUE: motion commands are refused meanwhile.  Aborts the running motion command.
struct MC_Stop {
    bool Execute = false;
    bool Done = false;
    bool Busy = false;
    bool CommandAborted = false;
    bool Error = false;
    int32_t ErrorID = 0;
    // Memory
    Command Internal;
    bool Holding = false;  // this instance's request holds the group (GroupStatus::StopSeq)

    void operator()(AxisGroupRef &AxesGroup);
};

// Clears the group's error (op-code 6: eState 4 -> 0 disabled or 1 standstill).  A group not in
// error needs nothing: Done at once, no request sent (so a reset never aborts a running motion).
struct MC_Reset {
    bool Execute = false;
    bool Done = false;
    bool Busy = false;
    bool CommandAborted = false;
    bool Error = false;
    int32_t ErrorID = 0;
    // Memory
    Command Internal;

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
struct MC_Power {
    bool Enable = false;
    bool Status = false;
    bool Valid = false;
    bool Busy = false;
    bool Error = false;
    int32_t ErrorID = 0;
    // Memory
    struct Memory {
        bool lastEnable = false;
        bool pending = false;  // a request of ours awaits its answer
        bool error = false;
        bool wasPowered = false;  // Powered was seen while enabled
        bool retry = false;       // power on again once the group's error is cleared
        uint32_t seq = 0;
        int32_t errorId = 0;
    } Internal;

    void operator()(AxisGroupRef &AxesGroup);

private:
    void issue(AxisGroupRef &group, OpCode op);
};

// The measured joint angles (ROBOT_MODULE_STATE.dCurJoint), read continuously while Enable.
struct MC_ReadActualPosition {
    bool Enable = false;
    bool Valid = false;
    bool Busy = false;
    bool Error = false;
    int32_t ErrorID = 0;
    Axes Position{};  // rad; 0 while not Valid

    void operator()(const AxisGroupRef &AxesGroup);
};

// The group's state in PLCopen's terms, read continuously while Enable (one of the states is TRUE
// while Valid): ErrorStop (eState 4 or Error), Disabled (eState 0), Stopping (eState 3, or an
// MC_Stop holds the group), Homing (an MC_Home's request runs), Standstill (eState 1),
// DiscreteMotion / ContinuousMotion (eState 2 for a position move / a velocity motion: the kind
// of the latest request); SynchronizedMotion is always FALSE.  IsHomed (from PLCopen's
// MC_ReadAxisInfo): an MC_Home finished since the group was last seen unpowered.
struct MC_ReadStatus {
    bool Enable = false;
    bool Valid = false;
    bool Busy = false;
    bool Error = false;
    int32_t ErrorID = 0;
    bool ErrorStop = false;
    bool Disabled = false;
    bool Stopping = false;
    bool Homing = false;
    bool Standstill = false;
    bool DiscreteMotion = false;
    bool ContinuousMotion = false;
    bool SynchronizedMotion = false;
    bool IsHomed = false;

    void operator()(const AxisGroupRef &AxesGroup);
};

// The robot's ErrorID while the group is in error (eState 4 or Error), else 0, read continuously
// while Enable: MC_ReadAxisError (PLCopen Part 1: AxisErrorID) and MC_GroupReadError (Part 4:
// GroupErrorID) read the same.  Error/ErrorID: the block's own failure (an unbound group).
struct MC_ReadAxisError {
    bool Enable = false;
    bool Valid = false;
    bool Busy = false;
    bool Error = false;
    int32_t ErrorID = 0;
    int32_t AxisErrorID = 0;

    void operator()(const AxisGroupRef &AxesGroup);
};

struct MC_GroupReadError {
    bool Enable = false;
    bool Valid = false;
    bool Busy = false;
    bool Error = false;
    int32_t ErrorID = 0;
    int32_t GroupErrorID = 0;

    void operator()(const AxisGroupRef &AxesGroup);
};

// Plain values, as the Structured Text runtime keeps FB instances (copied in and out of shared
// memory each period): no pointer, no constructor that matters, one layout.
template <class T>
inline constexpr bool kPlainBlock = std::is_trivially_copyable_v<T> &&std::is_standard_layout_v<T>;
static_assert(kPlainBlock<GroupStatus> && kPlainBlock<Command>);
static_assert(kPlainBlock<MC_Power> && kPlainBlock<MC_Home> && kPlainBlock<MC_MoveAbsolute> &&
              kPlainBlock<MC_MoveRelative> && kPlainBlock<MC_MoveLinear> && kPlainBlock<MC_MoveVelocity> &&
              kPlainBlock<MC_Stop> && kPlainBlock<MC_Reset>);
static_assert(kPlainBlock<MC_ReadActualPosition> && kPlainBlock<MC_ReadStatus> && kPlainBlock<MC_ReadAxisError> &&
              kPlainBlock<MC_GroupReadError>);

}  // namespace plcopen
