// axis_group.h -- the robot as the motion function blocks see it: pointers to the fields of the
// request/answer protocol of the plc-robot cell (docs/plc.md, notes of cell.glb) and to the PLC's
// own state of the group, and the one routine that writes a request.
//
// The blocks never name a shared variable: a program binds an AxisGroupRef to wherever those
// fields live (the PLC's process image of ROBOT_MODULE_SERVICE / ROBOT_MODULE_STATE in main.cpp,
// a simulated robot in the tests) with bindAxisGroup(service, state, status).  The reference is a
// view, built once or in every scan: all the state the blocks keep between scans is in the blocks
// and in the GroupStatus, plain values that may be copied in and out of shared memory.
//
// The protocol, requester side:
//   - a request is eOpCode, t_speed, t_accel, dTarget[6], then nSeq = nSeq + 1 (nSeq last);
//   - the robot takes it when nSeq != nAckSeq: nAckSeq = nSeq, and answers in the state fields;
//   - request `seq` is done when nAckSeq == seq && MotionDone, failed when nAckSeq == seq && Error,
//     and superseded as soon as a later request was written (nSeq) or taken (nAckSeq).
// Real-time safe: no allocation, no locks, no system calls.
#pragma once

#include <cstdint>

namespace plcopen {

inline constexpr int kAxes = 6;

// ROBOT_MODULE_SERVICE.eOpCode
enum class OpCode : int32_t {
    None = 0,
    PowerOn = 1,
    PowerOff = 2,
    MoveJ = 3,  // dTarget: 6 joint angles (rad)
    MoveL = 4,  // dTarget: x y z (m), roll pitch yaw (rad), base frame
    Stop = 5,
    Reset = 6,
    MoveVelocity = 7,  // dTarget: 6 joint velocities, signed fractions [-1, 1] of each joint's limit
};

// ROBOT_MODULE_STATE.eState
enum class GroupState : int16_t {
    Disabled = 0,
    Standstill = 1,
    Moving = 2,
    Stopping = 3,
    ErrorStop = 4,
};

// ErrorIDs the blocks report themselves.  The robot's own ErrorIDs (1 not powered, 2 joint
// limits, 3 unreachable, 4 drive fault, 5 following error, 6 power-on timeout, 7 bad op-code,
// 8 communication lost) pass through unchanged; the PLC's start at 1000 so that they never meet.
namespace error {
inline constexpr int32_t kInvalidParameter = 1001;  // Velocity/Acceleration outside (0, 1], a target not finite
inline constexpr int32_t kGroupStopping = 1002;     // an MC_Stop holds the group (its Execute is still high)
inline constexpr int32_t kNotBound = 1003;          // the AxisGroupRef lacks a field
inline constexpr int32_t kUnspecified = 1004;       // the robot reported Error with ErrorID 0
inline constexpr int32_t kMotionEnded = 1005;       // the robot ended a velocity motion on its own (no command)
}  // namespace error

// `a` is a later sequence number than `b` (wraps around like the uint32_t counters).
constexpr bool seqAfter(uint32_t a, uint32_t b) { return static_cast<int32_t>(a - b) > 0; }

// The PLC's own state of an axis group, shared by the blocks that command it (not part of the
// protocol): which MC_Stop holds the group in "stopping", and whether MC_Home referenced it.
// Plain values, so that a program keeps it wherever it keeps its variables (a shared variable).
struct GroupStatus {
    uint32_t StopSeq = 0;   // the request of the MC_Stop that holds the group
    uint32_t HomeSeq = 0;   // the request of the last MC_Home
    bool Stopping = false;  // an MC_Stop holds the group: motion commands are refused
    bool Homing = false;    // HomeSeq was written by an MC_Home
    bool Homed = false;     // an MC_Home finished; cleared when the group is seen unpowered
};

struct AxisGroupRef {
    // ROBOT_MODULE_SERVICE: written by the blocks.
    int32_t *eOpCode = nullptr;
    uint32_t *nSeq = nullptr;
    double *t_speed = nullptr;
    double *t_accel = nullptr;
    double *dTarget = nullptr;  // kAxes values

    // ROBOT_MODULE_STATE: read by the blocks.
    const int16_t *MotionDone = nullptr;
    const int16_t *Busy = nullptr;
    const int16_t *eState = nullptr;
    const int16_t *Powered = nullptr;
    const int16_t *Error = nullptr;
    const int32_t *ErrorID = nullptr;
    const uint32_t *nAckSeq = nullptr;
    const double *dCurJoint = nullptr;  // kAxes values: measured joint angles (rad)
    const double *dCmdJoint = nullptr;  // kAxes values: commanded joint angles (rad)

    // The PLC's state of the group, written by the blocks.
    GroupStatus *status = nullptr;

    bool bound() const {
        return eOpCode && nSeq && t_speed && t_accel && dTarget && MotionDone && Busy && eState && Powered && Error &&
               ErrorID && nAckSeq && dCurJoint && dCmdJoint && status;
    }

    // Writes one request (nSeq last) and returns its sequence number.  `target` (kAxes values) may
    // be null for requests without one; dTarget then keeps its previous value.
    uint32_t request(OpCode op, double speed, double accel, const double *target);

    // The answer to request `seq`.
    bool taken(uint32_t seq) const { return *nAckSeq == seq; }
    bool finished(uint32_t seq) const { return taken(seq) && *MotionDone != 0; }
    bool failed(uint32_t seq) const { return taken(seq) && *Error != 0; }
    // A later request was written or taken: `seq` no longer has the robot.
    bool superseded(uint32_t seq) const { return seqAfter(*nSeq, seq) || seqAfter(*nAckSeq, seq); }

    bool inError() const { return *Error != 0 || *eState == static_cast<int16_t>(GroupState::ErrorStop); }
    int32_t errorId() const { return *ErrorID != 0 ? *ErrorID : error::kUnspecified; }
    bool in(GroupState s) const { return *eState == static_cast<int16_t>(s); }

    // What every block does first in a call on a bound group: a group seen unpowered is no longer
    // homed (a robot is referenced again after its power returns).
    void observe() const {
        if (*Powered == 0) status->Homed = false;
    }
};

// Binds to any pair of structs that carry the protocol's fields under their cell.glb names
// (PLC_ROBOT::ROBOT_MODULE_SERVICE_t / ROBOT_MODULE_STATE_t, or a test's own) and to the group's
// status.  All three must outlive the reference.
template <class Service, class State>
AxisGroupRef bindAxisGroup(Service &service, const State &state, GroupStatus &status) {
    static_assert(sizeof(service.dTarget) / sizeof(service.dTarget[0]) == kAxes, "dTarget holds 6 values");
    static_assert(sizeof(state.dCurJoint) / sizeof(state.dCurJoint[0]) == kAxes, "dCurJoint holds 6 values");
    AxisGroupRef g;
    g.eOpCode = &service.eOpCode;
    g.nSeq = &service.nSeq;
    g.t_speed = &service.t_speed;
    g.t_accel = &service.t_accel;
    g.dTarget = &service.dTarget[0];
    g.MotionDone = &state.MotionDone;
    g.Busy = &state.Busy;
    g.eState = &state.eState;
    g.Powered = &state.Powered;
    g.Error = &state.Error;
    g.ErrorID = &state.ErrorID;
    g.nAckSeq = &state.nAckSeq;
    g.dCurJoint = &state.dCurJoint[0];
    g.dCmdJoint = &state.dCmdJoint[0];
    g.status = &status;
    return g;
}

}  // namespace plcopen
