// axis.cpp -- the simulated axis: CiA 402 transitions from the controlword, CSP motion with
// limits and a lag, braking outside operation enabled, following-error faults.
#include "axis.hpp"

#include <algorithm>
#include <cmath>

namespace irp::drivesim {

const char *toString(State s) {
    switch (s) {
    case State::NotReadyToSwitchOn: return "not ready to switch on";
    case State::SwitchOnDisabled: return "switch on disabled";
    case State::ReadyToSwitchOn: return "ready to switch on";
    case State::SwitchedOn: return "switched on";
    case State::OperationEnabled: return "operation enabled";
    case State::QuickStopActive: return "quick stop active";
    case State::FaultReactionActive: return "fault reaction active";
    case State::Fault: return "fault";
    }
    return "?";
}

Axis::Axis(const AxisParams &params)
    : params_(params),
      target_(static_cast<int32_t>(std::lround(params.initial_position))),
      pos_(params.initial_position) {}

void Axis::setControlword(uint16_t controlword) {
    if ((controlword & cw::kFaultReset) && !(controlword_ & cw::kFaultReset)) reset_edge_ = true;
    controlword_ = controlword;
}

void Axis::injectFault(uint16_t error_code) {
    fault_pending_ = true;
    pending_error_ = error_code;
}

namespace {

// The device control commands of CiA 402 (bits 0-3; bit 7 = fault reset is handled apart).
enum class Command { DisableVoltage, QuickStop, Shutdown, SwitchOn, EnableOperation };

Command decode(uint16_t c) {
    if (!(c & cw::kEnableVoltage)) return Command::DisableVoltage;
    if (!(c & cw::kQuickStop)) return Command::QuickStop;
    if (!(c & cw::kSwitchOn)) return Command::Shutdown;
    if (!(c & cw::kEnableOperation)) return Command::SwitchOn;
    return Command::EnableOperation;
}

}  // namespace

void Axis::transition(double /*dt*/) {
    if (fault_pending_ && state_ != State::Fault && state_ != State::FaultReactionActive) {
        state_ = State::FaultReactionActive;
        error_ = pending_error_;
    }
    fault_pending_ = false;
    const bool reset = reset_edge_;
    reset_edge_ = false;
    const Command c = decode(controlword_);
    switch (state_) {
    case State::NotReadyToSwitchOn:
        state_ = State::SwitchOnDisabled;  // transition 1: the drive's self-test is instant here
        break;
    case State::SwitchOnDisabled:
        if (c == Command::Shutdown) state_ = State::ReadyToSwitchOn;  // 2
        break;
    case State::ReadyToSwitchOn:
        if (c == Command::SwitchOn || c == Command::EnableOperation)
            state_ = State::SwitchedOn;  // 3 (then 4)
        else if (c == Command::DisableVoltage || c == Command::QuickStop)
            state_ = State::SwitchOnDisabled;  // 7
        break;
    case State::SwitchedOn:
        if (c == Command::EnableOperation) {
            state_ = State::OperationEnabled;  // 4
        } else if (c == Command::Shutdown)
            state_ = State::ReadyToSwitchOn;  // 6
        else if (c == Command::DisableVoltage || c == Command::QuickStop)
            state_ = State::SwitchOnDisabled;  // 10
        break;
    case State::OperationEnabled:
        if (c == Command::SwitchOn)
            state_ = State::SwitchedOn;  // 5
        else if (c == Command::Shutdown)
            state_ = State::ReadyToSwitchOn;  // 8
        else if (c == Command::DisableVoltage)
            state_ = State::SwitchOnDisabled;  // 9
        else if (c == Command::QuickStop)
            state_ = State::QuickStopActive;  // 11
        break;
    case State::QuickStopActive:  // quick stop option code 6: brake, then stay here
        if (c == Command::DisableVoltage)
            state_ = State::SwitchOnDisabled;  // 12
        else if (c == Command::EnableOperation && vel_ == 0)
            state_ = State::OperationEnabled;  // 16
        break;
    case State::FaultReactionActive:
        if (vel_ == 0) state_ = State::Fault;  // 14: braked to standstill
        break;
    case State::Fault:
        if (reset) {  // 15
            state_ = State::SwitchOnDisabled;
            error_ = 0;
            following_error_ = false;
        }
        break;
    }
}

void Axis::brake(double dt) {
    const double dv = params_.max_acceleration * dt;
    if (std::abs(vel_) <= dv)
        vel_ = 0;
    else
        vel_ -= std::copysign(dv, vel_);
    pos_ += vel_ * dt;
}

void Axis::move(double dt) {
    // Position loop: the velocity that closes the error with time constant lag_s, never faster
    // than max_velocity nor than what max_acceleration can still brake before the target.
    const double e = static_cast<double>(target_) - pos_;
    double v = e / params_.lag_s;
    const double v_brake = std::sqrt(2.0 * params_.max_acceleration * std::abs(e));
    v = std::copysign(std::min({std::abs(v), v_brake, params_.max_velocity}), e);
    const double dv = std::clamp(v - vel_, -params_.max_acceleration * dt, params_.max_acceleration * dt);
    vel_ += dv;
    pos_ += vel_ * dt;
    if (std::abs(static_cast<double>(target_) - pos_) > params_.following_limit) {
        following_error_ = true;
        error_ = kErrorFollowing;
        state_ = State::FaultReactionActive;
    }
}

void Axis::step(double dt) {
    transition(dt);
    if (state_ == State::OperationEnabled && mode_ == kModeCsp)
        move(dt);
    else
        brake(dt);
}

uint16_t Axis::statusword() const {
    uint16_t s = sw::kRemote;
    switch (state_) {
    case State::NotReadyToSwitchOn: s = 0; break;
    case State::SwitchOnDisabled: s |= sw::kSwitchOnDisabled; break;
    case State::ReadyToSwitchOn: s |= sw::kQuickStop | sw::kVoltageEnabled | sw::kReadyToSwitchOn; break;
    case State::SwitchedOn: s |= sw::kQuickStop | sw::kVoltageEnabled | sw::kReadyToSwitchOn | sw::kSwitchedOn; break;
    case State::OperationEnabled:
        s |= sw::kQuickStop | sw::kVoltageEnabled | sw::kReadyToSwitchOn | sw::kSwitchedOn | sw::kOperationEnabled;
        if (mode_ == kModeCsp) s |= sw::kFollowsTarget;
        break;
    case State::QuickStopActive:
        s |= sw::kVoltageEnabled | sw::kReadyToSwitchOn | sw::kSwitchedOn | sw::kOperationEnabled;
        break;
    case State::FaultReactionActive:
        s |= sw::kReadyToSwitchOn | sw::kSwitchedOn | sw::kOperationEnabled | sw::kFault;
        break;
    case State::Fault: s |= sw::kFault; break;
    }
    if (state_ == State::OperationEnabled && std::abs(static_cast<double>(target_) - pos_) <= params_.target_window &&
        std::abs(vel_) * params_.lag_s <= params_.target_window)
        s |= sw::kTargetReached;
    if (following_error_) s |= sw::kFollowingError;
    return s;
}

namespace {
int32_t saturate(double v) { return static_cast<int32_t>(std::clamp(std::round(v), -2147483648.0, 2147483647.0)); }
}  // namespace

int32_t Axis::position() const { return saturate(pos_); }
int32_t Axis::velocity() const { return saturate(vel_); }

}  // namespace irp::drivesim
