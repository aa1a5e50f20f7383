// motion.cpp -- the PLCopen-style motion blocks (motion.h): the Execute/Done/Busy state machine
// they share, and what each one requests and how it reads the robot's answer.
#include <indurop/plcopen/motion.h>

#include <cmath>

namespace plcopen {

// ---- ExecuteBlock ------------------------------------------------------------------------------

bool ExecuteBlock::begin() {
    const bool edge = Execute && !lastExecute_;
    lastExecute_ = Execute;
    // An outcome reached in an earlier call has been shown (publish() ran then); with Execute
    // FALSE it is cleared now.  So it stays while Execute stays TRUE, or shows once if Execute
    // fell while the command was busy.
    const bool outcome = phase_ == Phase::Done || phase_ == Phase::Error || phase_ == Phase::Aborted;
    if (outcome && !Execute) {
        phase_ = Phase::Idle;
        errorId_ = 0;
    }
    return edge;
}

void ExecuteBlock::issue(AxisGroupRef &group, OpCode op, double speed, double accel, const double *target) {
    seq_ = group.request(op, speed, accel, target);
    phase_ = Phase::Issued;
    errorId_ = 0;
}

void ExecuteBlock::fail(int32_t id) {
    phase_ = Phase::Error;
    errorId_ = id;
}

void ExecuteBlock::track(const AxisGroupRef &group) {
    if (!running()) return;
    // The answer to our own request first: a result the robot gave for it is the truth even if
    // a later request was written in the meantime.
    if (group.failed(seq_)) {
        phase_ = Phase::Error;
        errorId_ = group.errorId();
    } else if (group.finished(seq_)) {
        phase_ = Phase::Done;
    } else if (group.superseded(seq_)) {
        phase_ = Phase::Aborted;
    } else if (group.taken(seq_)) {
        phase_ = Phase::Taken;
    }
}

void ExecuteBlock::publish() {
    Busy = running();
    Done = phase_ == Phase::Done;
    Error = phase_ == Phase::Error;
    CommandAborted = phase_ == Phase::Aborted;
    ErrorID = Error ? errorId_ : 0;
}

// ---- MC_MoveAbsolute, MC_MoveLinear ------------------------------------------------------------

namespace {

bool fraction(double v) { return std::isfinite(v) && v > 0.0 && v <= 1.0; }

}  // namespace

void MoveCommand::cycle(AxisGroupRef &group, OpCode op) {
    if (begin()) {
        bool finite = true;
        for (double p : Position) finite = finite && std::isfinite(p);
        if (!group.bound())
            fail(error::kNotBound);
        else if (!finite || !fraction(Velocity) || !fraction(Acceleration))
            fail(error::kInvalidParameter);
        else if (group.stopHolder)
            fail(error::kGroupStopping);
        else
            issue(group, op, Velocity, Acceleration, Position.data());
    }
    if (group.bound()) track(group);
    publish();
    Active = phase_ == Phase::Taken;
}

// ---- MC_Stop -----------------------------------------------------------------------------------

void MC_Stop::operator()(AxisGroupRef &AxesGroup) {
    if (begin()) {
        if (!AxesGroup.bound()) {
            fail(error::kNotBound);
        } else {
            issue(AxesGroup, OpCode::Stop, 0.0, 0.0, nullptr);
            AxesGroup.stopHolder = this;
        }
    }
    if (AxesGroup.bound()) track(AxesGroup);
    // The group stays "stopping" while Execute is TRUE and until the stop is over.
    if (AxesGroup.stopHolder == this && !Execute && !running()) AxesGroup.stopHolder = nullptr;
    publish();
}

// ---- MC_Reset ----------------------------------------------------------------------------------

void MC_Reset::operator()(AxisGroupRef &AxesGroup) {
    if (begin()) {
        if (!AxesGroup.bound())
            fail(error::kNotBound);
        else if (!AxesGroup.inError())
            succeed();  // nothing to reset
        else
            issue(AxesGroup, OpCode::Reset, 0.0, 0.0, nullptr);
    }
    if (running() && AxesGroup.bound()) {
        // The group's Error was already set when the reset was requested, so it only counts as
        // the reset's failure once the robot has taken the reset and is no longer busy with it.
        if (AxesGroup.taken(seq_)) {
            if (*AxesGroup.Busy) {
                phase_ = Phase::Taken;
            } else if (*AxesGroup.Error) {
                phase_ = Phase::Error;
                errorId_ = AxesGroup.errorId();
            } else if (!AxesGroup.inError()) {
                phase_ = Phase::Done;
            } else {
                phase_ = Phase::Taken;
            }
        } else if (AxesGroup.superseded(seq_)) {
            phase_ = Phase::Aborted;
        }
    }
    publish();
}

// ---- MC_Power ----------------------------------------------------------------------------------

void MC_Power::issue(AxisGroupRef &group, OpCode op) {
    seq_ = group.request(op, 0.0, 0.0, nullptr);
    pending_ = true;
}

void MC_Power::operator()(AxisGroupRef &AxesGroup) {
    const bool rise = Enable && !lastEnable_;
    const bool fall = !Enable && lastEnable_;
    lastEnable_ = Enable;
    if (!AxesGroup.bound()) {
        Status = Valid = Busy = false;
        Error = Enable;
        ErrorID = Enable ? error::kNotBound : 0;
        return;
    }

    // The robot's answer to our request.
    if (pending_) {
        if (AxesGroup.failed(seq_)) {
            pending_ = false;
            if (Enable) {
                error_ = true;
                errorId_ = AxesGroup.errorId();
            }
        } else if (AxesGroup.finished(seq_) || AxesGroup.superseded(seq_)) {
            pending_ = false;
        }
    }

    const bool powered = *AxesGroup.Powered != 0;
    const bool groupError = AxesGroup.inError();
    if (fall) {
        error_ = retry_ = wasPowered_ = false;
        if (powered || pending_) issue(AxesGroup, OpCode::PowerOff);
    } else if (rise) {
        error_ = false;
        if (groupError) {  // the robot would refuse: wait for MC_Reset, then power on
            error_ = retry_ = true;
            errorId_ = AxesGroup.errorId();
        } else if (!powered || pending_) {  // pending_: our power-off is on its way
            issue(AxesGroup, OpCode::PowerOn);
        }
    } else if (Enable) {
        if (groupError) {
            retry_ = true;
            if (wasPowered_ && !powered && !error_) {  // power lost: a drive fault, lost communication
                error_ = true;
                errorId_ = AxesGroup.errorId();
            }
        } else {
            if (error_ && !pending_) error_ = false;  // the group's error was reset
            if (retry_ && !powered && !pending_) issue(AxesGroup, OpCode::PowerOn);
            retry_ = false;
        }
    }
    if (Enable && powered) wasPowered_ = true;

    Status = powered;
    Busy = pending_;
    Valid = Enable && !error_;
    Error = Enable && error_;
    ErrorID = Error ? errorId_ : 0;
}

// ---- MC_GroupReadError -------------------------------------------------------------------------

void MC_GroupReadError::operator()(const AxisGroupRef &AxesGroup) {
    Busy = false;
    if (!Enable) {
        Valid = Error = false;
        ErrorID = GroupErrorID = 0;
        return;
    }
    if (!AxesGroup.bound()) {
        Valid = false;
        Error = true;
        ErrorID = error::kNotBound;
        GroupErrorID = 0;
        return;
    }
    Valid = true;
    Error = false;
    ErrorID = 0;
    GroupErrorID = AxesGroup.inError() ? AxesGroup.errorId() : 0;
}

}  // namespace plcopen
