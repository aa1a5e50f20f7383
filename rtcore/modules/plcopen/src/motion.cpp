// motion.cpp -- the PLCopen motion blocks (motion.h): the Execute/Done/Busy state machine they
// share, and what each one requests and how it reads the robot's answer.
#include <indurop/plcopen/motion.h>

#include <cmath>

namespace plcopen {

using Phase = Command::Phase;

// ---- Command -----------------------------------------------------------------------------------

bool Command::begin(bool execute) {
    const bool edge = execute && !lastExecute;
    lastExecute = execute;
    // An outcome reached in an earlier call has been shown (publish() ran then); with Execute
    // FALSE it is cleared now.  So it stays while Execute stays TRUE, or shows once if Execute
    // fell while the command was busy.
    const bool outcome = phase == Phase::Done || phase == Phase::Error || phase == Phase::Aborted;
    if (outcome && !execute) {
        phase = Phase::Idle;
        errorId = 0;
    }
    return edge;
}

void Command::issue(AxisGroupRef &group, OpCode op, double speed, double accel, const double *target) {
    seq = group.request(op, speed, accel, target);
    phase = Phase::Issued;
    errorId = 0;
}

void Command::fail(int32_t id) {
    phase = Phase::Error;
    errorId = id;
}

void Command::track(const AxisGroupRef &group) {
    if (!running()) return;
    // The answer to our own request first: a result the robot gave for it is the truth even if
    // a later request was written in the meantime.
    if (group.failed(seq)) {
        fail(group.errorId());
    } else if (group.finished(seq)) {
        phase = Phase::Done;
    } else if (group.superseded(seq)) {
        phase = Phase::Aborted;
    } else if (group.taken(seq)) {
        phase = Phase::Taken;
    }
}

namespace {

bool fraction(double v) { return std::isfinite(v) && v > 0.0 && v <= 1.0; }

bool finite(const Axes &v) {
    for (double x : v)
        if (!std::isfinite(x)) return false;
    return true;
}

// A bound group, observed for this call (axis_group.h).
bool ready(const AxisGroupRef &group) {
    if (!group.bound()) return false;
    group.observe();
    return true;
}

// Why a motion command may not start (0: it may): the group unbound, bad parameters, or held by
// an MC_Stop.
int32_t refusal(bool bound, bool valid, const AxisGroupRef &group) {
    if (!bound) return error::kNotBound;
    if (!valid) return error::kInvalidParameter;
    if (group.status->Stopping) return error::kGroupStopping;
    return 0;
}

// One call of a move to a target position: the request at the rising edge (to target(), computed
// then), the robot's answer after.  True in the call that wrote the request.
template <class Block, class Target>
bool moveCycle(Block &b, AxisGroupRef &group, OpCode op, Target target) {
    const bool bound = ready(group);
    bool issued = false;
    if (b.Internal.begin(b.Execute)) {
        Axes to{};
        if (bound) to = target();
        const int32_t refused = refusal(bound, finite(to) && fraction(b.Velocity) && fraction(b.Acceleration), group);
        if (refused) {
            b.Internal.fail(refused);
        } else {
            b.Internal.issue(group, op, b.Velocity, b.Acceleration, to.data());
            issued = true;
        }
    }
    if (bound) b.Internal.track(group);
    b.Internal.publish(b);
    b.Active = b.Internal.taken();
    return issued;
}

}  // namespace

// ---- MC_MoveAbsolute, MC_MoveLinear, MC_MoveRelative, MC_Home --------------------------------

void MC_MoveAbsolute::operator()(AxisGroupRef &AxesGroup) {
    moveCycle(*this, AxesGroup, OpCode::MoveJ, [this] { return Position; });
}

void MC_MoveLinear::operator()(AxisGroupRef &AxesGroup) {
    moveCycle(*this, AxesGroup, OpCode::MoveL, [this] { return Position; });
}

void MC_MoveRelative::operator()(AxisGroupRef &AxesGroup) {
    moveCycle(*this, AxesGroup, OpCode::MoveJ, [this, &AxesGroup] {
        Axes to;
        for (int i = 0; i < kAxes; ++i) to[i] = AxesGroup.dCmdJoint[i] + Distance[i];
        return to;
    });
}

void MC_Home::operator()(AxisGroupRef &AxesGroup) {
    const bool wasRunning = Internal.running();
    if (moveCycle(*this, AxesGroup, OpCode::MoveJ, [this] { return Position; })) {
        GroupStatus &s = *AxesGroup.status;
        s.Homing = true;
        s.HomeSeq = Internal.seq;
        s.Homed = false;  // referenced again by this move
    }
    if (wasRunning && Internal.phase == Phase::Done && AxesGroup.status->HomeSeq == Internal.seq)
        AxesGroup.status->Homed = true;
}

// ---- MC_MoveVelocity ---------------------------------------------------------------------------

void MC_MoveVelocity::operator()(AxisGroupRef &AxesGroup) {
    const bool bound = ready(AxesGroup);
    if (Internal.begin(Execute)) {
        bool valid = finite(Velocity) && fraction(Acceleration);
        bool moves = false;
        for (double v : Velocity) {
            valid = valid && std::abs(v) <= 1.0;
            moves = moves || v != 0.0;
        }
        const int32_t refused = refusal(bound, valid && moves, AxesGroup);
        if (refused)
            Internal.fail(refused);
        else  // t_speed is not used by a velocity request (dTarget holds the speeds)
            Internal.issue(AxesGroup, OpCode::MoveVelocity, 1.0, Acceleration, Velocity.data());
    }
    bool inVelocity = false;
    if (bound && Internal.running()) {
        // The request never finishes by itself: it runs until a later request takes over, the
        // robot fails it (a fault, a joint at its limit), or the robot drops it.
        if (AxesGroup.failed(Internal.seq)) {
            Internal.fail(AxesGroup.errorId());
        } else if (AxesGroup.superseded(Internal.seq)) {
            Internal.phase = Phase::Aborted;
        } else if (AxesGroup.taken(Internal.seq)) {
            if (AxesGroup.in(GroupState::Moving)) {
                Internal.phase = Phase::Taken;
                inVelocity = *AxesGroup.MotionDone != 0;  // the robot holds the commanded velocity
            } else {
                Internal.fail(error::kMotionEnded);
            }
        }
    }
    Internal.publish(*this);
    Active = Internal.taken();
    InVelocity = inVelocity && Active;
}

// ---- MC_Stop -----------------------------------------------------------------------------------

void MC_Stop::operator()(AxisGroupRef &AxesGroup) {
    const bool bound = ready(AxesGroup);
    if (Internal.begin(Execute)) {
        if (!bound) {
            Internal.fail(error::kNotBound);
        } else {
            Internal.issue(AxesGroup, OpCode::Stop, 0.0, 0.0, nullptr);
            AxesGroup.status->Stopping = true;
            AxesGroup.status->StopSeq = Internal.seq;
            Holding = true;
        }
    }
    if (bound) {
        Internal.track(AxesGroup);
        // The group stays "stopping" while Execute is TRUE and until the stop is over; a later
        // MC_Stop that took the group over releases it instead.
        GroupStatus &s = *AxesGroup.status;
        if (Holding && !(s.Stopping && s.StopSeq == Internal.seq)) {
            Holding = false;
        } else if (Holding && !Execute && !Internal.running()) {
            s.Stopping = false;
            Holding = false;
        }
    }
    Internal.publish(*this);
}

// ---- MC_Reset ----------------------------------------------------------------------------------

void MC_Reset::operator()(AxisGroupRef &AxesGroup) {
    const bool bound = ready(AxesGroup);
    if (Internal.begin(Execute)) {
        if (!bound)
            Internal.fail(error::kNotBound);
        else if (!AxesGroup.inError())
            Internal.succeed();  // nothing to reset
        else
            Internal.issue(AxesGroup, OpCode::Reset, 0.0, 0.0, nullptr);
    }
    if (Internal.running() && bound) {
        // The group's Error was already set when the reset was requested, so it only counts as
        // the reset's failure once the robot has taken the reset and is no longer busy with it.
        if (AxesGroup.taken(Internal.seq)) {
            if (*AxesGroup.Busy) {
                Internal.phase = Phase::Taken;
            } else if (*AxesGroup.Error) {
                Internal.fail(AxesGroup.errorId());
            } else if (!AxesGroup.inError()) {
                Internal.phase = Phase::Done;
            } else {
                Internal.phase = Phase::Taken;
            }
        } else if (AxesGroup.superseded(Internal.seq)) {
            Internal.phase = Phase::Aborted;
        }
    }
    Internal.publish(*this);
}

// ---- MC_Power ----------------------------------------------------------------------------------

void MC_Power::issue(AxisGroupRef &group, OpCode op) {
    Internal.seq = group.request(op, 0.0, 0.0, nullptr);
    Internal.pending = true;
}

void MC_Power::operator()(AxisGroupRef &AxesGroup) {
    Memory &m = Internal;
    const bool rise = Enable && !m.lastEnable;
    const bool fall = !Enable && m.lastEnable;
    m.lastEnable = Enable;
    if (!ready(AxesGroup)) {
        Status = Valid = Busy = false;
        Error = Enable;
        ErrorID = Enable ? error::kNotBound : 0;
        return;
    }

    // The robot's answer to our request.
    if (m.pending) {
        if (AxesGroup.failed(m.seq)) {
            m.pending = false;
            if (Enable) {
                m.error = true;
                m.errorId = AxesGroup.errorId();
            }
        } else if (AxesGroup.finished(m.seq) || AxesGroup.superseded(m.seq)) {
            m.pending = false;
        }
    }

    const bool powered = *AxesGroup.Powered != 0;
    const bool groupError = AxesGroup.inError();
    if (fall) {
        m.error = m.retry = m.wasPowered = false;
        if (powered || m.pending) issue(AxesGroup, OpCode::PowerOff);
    } else if (rise) {
        m.error = false;
        if (groupError) {  // the robot would refuse: wait for MC_Reset, then power on
            m.error = m.retry = true;
            m.errorId = AxesGroup.errorId();
        } else if (!powered || m.pending) {  // pending: our power-off is on its way
            issue(AxesGroup, OpCode::PowerOn);
        }
    } else if (Enable) {
        if (groupError) {
            m.retry = true;
            if (m.wasPowered && !powered && !m.error) {  // power lost: a drive fault, lost communication
                m.error = true;
                m.errorId = AxesGroup.errorId();
            }
        } else {
            if (m.error && !m.pending) m.error = false;  // the group's error was reset
            if (m.retry && !powered && !m.pending) issue(AxesGroup, OpCode::PowerOn);
            m.retry = false;
        }
    }
    if (Enable && powered) m.wasPowered = true;

    Status = powered;
    Busy = m.pending;
    Valid = Enable && !m.error;
    Error = Enable && m.error;
    ErrorID = Error ? m.errorId : 0;
}

// ---- the Read blocks ---------------------------------------------------------------------------

namespace {

// The outputs every Read block shares; true when the block reads the group in this call (Enable
// on a bound group).  Otherwise the caller sets its values to 0.
template <class Block>
bool readCall(Block &b, const AxisGroupRef &group) {
    const bool bound = b.Enable && ready(group);
    b.Busy = false;
    b.Valid = bound;
    b.Error = b.Enable && !bound;
    b.ErrorID = b.Error ? error::kNotBound : 0;
    return bound;
}

int32_t groupErrorId(const AxisGroupRef &group) { return group.inError() ? group.errorId() : 0; }

}  // namespace

void MC_ReadActualPosition::operator()(const AxisGroupRef &AxesGroup) {
    const bool read = readCall(*this, AxesGroup);
    for (int i = 0; i < kAxes; ++i) Position[i] = read ? AxesGroup.dCurJoint[i] : 0.0;
}

void MC_ReadStatus::operator()(const AxisGroupRef &AxesGroup) {
    ErrorStop = Disabled = Stopping = Homing = Standstill = DiscreteMotion = ContinuousMotion = false;
    SynchronizedMotion = IsHomed = false;
    if (!readCall(*this, AxesGroup)) return;
    const AxisGroupRef &g = AxesGroup;
    const GroupStatus &s = *g.status;
    IsHomed = s.Homed;
    if (g.inError()) {
        ErrorStop = true;
    } else if (g.in(GroupState::Stopping) || (s.Stopping && !g.in(GroupState::Disabled))) {
        Stopping = true;
    } else if (s.Homing && !g.superseded(s.HomeSeq) && !g.finished(s.HomeSeq) && !g.failed(s.HomeSeq)) {
        Homing = true;
    } else if (g.in(GroupState::Moving)) {
        const bool velocity = *g.eOpCode == static_cast<int32_t>(OpCode::MoveVelocity);
        ContinuousMotion = velocity;
        DiscreteMotion = !velocity;
    } else if (g.in(GroupState::Standstill)) {
        Standstill = true;
    } else {
        Disabled = true;
    }
}

void MC_ReadAxisError::operator()(const AxisGroupRef &AxesGroup) {
    AxisErrorID = readCall(*this, AxesGroup) ? groupErrorId(AxesGroup) : 0;
}

void MC_GroupReadError::operator()(const AxisGroupRef &AxesGroup) {
    GroupErrorID = readCall(*this, AxesGroup) ? groupErrorId(AxesGroup) : 0;
}

}  // namespace plcopen
