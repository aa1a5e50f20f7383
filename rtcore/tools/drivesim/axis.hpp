// axis.hpp -- one simulated servo axis: the CiA 402 drive state machine (controlword in,
// statusword out) and cyclic synchronous position (mode 8) with velocity and acceleration limits,
// a first-order lag and following-error detection.  Pure computation, no I/O: the Modbus server
// (main.cpp) and the CAN tests step it at 1 kHz.
//
//   irp::drivesim::Axis axis(params);
//   axis.setControlword(0x06);  axis.setMode(8);  axis.setTarget(counts);   // whenever they arrive
//   axis.step(0.001);                                                        // every 1 ms
//   axis.statusword(); axis.position(); axis.velocity(); axis.errorCode();
#pragma once

#include <cstdint>

namespace irp::drivesim {

// CiA 402 controlword bits and commands (the contract, /work/notes/cell-contract.md).
namespace cw {
inline constexpr uint16_t kSwitchOn = 0x0001;
inline constexpr uint16_t kEnableVoltage = 0x0002;
inline constexpr uint16_t kQuickStop = 0x0004;  // active low: 0 requests a quick stop
inline constexpr uint16_t kEnableOperation = 0x0008;
inline constexpr uint16_t kFaultReset = 0x0080;  // rising edge
inline constexpr uint16_t kShutdown = 0x0006;
inline constexpr uint16_t kSwitchOnCmd = 0x0007;
inline constexpr uint16_t kEnableOperationCmd = 0x000F;
inline constexpr uint16_t kDisableVoltage = 0x0000;
inline constexpr uint16_t kQuickStopCmd = 0x0002;
}  // namespace cw

// Statusword bits; the state is statusword & 0x6F (0x4F for switch on disabled).
namespace sw {
inline constexpr uint16_t kReadyToSwitchOn = 0x0001;
inline constexpr uint16_t kSwitchedOn = 0x0002;
inline constexpr uint16_t kOperationEnabled = 0x0004;
inline constexpr uint16_t kFault = 0x0008;
inline constexpr uint16_t kVoltageEnabled = 0x0010;
inline constexpr uint16_t kQuickStop = 0x0020;  // 1: no quick stop in progress
inline constexpr uint16_t kSwitchOnDisabled = 0x0040;
inline constexpr uint16_t kRemote = 0x0200;
inline constexpr uint16_t kTargetReached = 0x0400;
inline constexpr uint16_t kFollowsTarget = 0x1000;  // CSP: the drive follows the target
inline constexpr uint16_t kFollowingError = 0x2000;
}  // namespace sw

// Error codes (CiA 402 / CiA 301 emergency codes).
inline constexpr uint16_t kErrorFollowing = 0x8611;    // following error
inline constexpr uint16_t kErrorInjected = 0xFF00;     // raised through the fault-injection register
inline constexpr uint16_t kErrorCommTimeout = 0x8130;  // the master went silent (life guard / heartbeat error)

inline constexpr int8_t kModeCsp = 8;

enum class State : uint8_t {
    NotReadyToSwitchOn,
    SwitchOnDisabled,
    ReadyToSwitchOn,
    SwitchedOn,
    OperationEnabled,
    QuickStopActive,
    FaultReactionActive,
    Fault,
};
const char *toString(State s);

struct AxisParams {
    double max_velocity = 600000;       // counts/s
    double max_acceleration = 5000000;  // counts/s^2 (also the quick-stop and disable deceleration)
    double lag_s = 0.004;               // time constant of the position loop (first-order lag)
    double following_limit = 10000;     // counts: |target - actual| above this in CSP -> fault 0x8611
    double target_window = 50;          // counts: statusword bit 10 "target reached" within this
    double initial_position = 0;        // counts
};

class Axis {
public:
    explicit Axis(const AxisParams &params = {});

    // Commands, applied at the next step (a rising edge of the fault-reset bit is latched here,
    // so that 0x80 followed by 0x00 before the next step still resets).
    void setControlword(uint16_t controlword);
    void setMode(int8_t mode) { mode_ = mode; }
    void setTarget(int32_t counts) { target_ = counts; }
    // Puts the axis in fault with this error code (fault injection, tests).
    void injectFault(uint16_t error_code);

    // Advances the simulation by dt seconds (1 ms in the simulator).
    void step(double dt);

    uint16_t statusword() const;
    uint16_t errorCode() const { return error_; }
    int8_t modeDisplay() const { return mode_; }
    int32_t position() const;  // counts, rounded
    int32_t velocity() const;  // counts/s, rounded
    double exactPosition() const { return pos_; }
    double followingError() const { return target_ - pos_; }  // counts (meaningful in CSP)
    State state() const { return state_; }
    uint16_t controlword() const { return controlword_; }
    int32_t target() const { return target_; }
    const AxisParams &params() const { return params_; }

private:
    void transition(double dt);
    void move(double dt);
    void brake(double dt);

    AxisParams params_;
    State state_ = State::NotReadyToSwitchOn;
    uint16_t controlword_ = 0;
    bool reset_edge_ = false;  // a rising edge of bit 7 since the last step
    int8_t mode_ = 0;
    int32_t target_ = 0;
    double pos_ = 0, vel_ = 0;
    uint16_t error_ = 0;
    bool following_error_ = false;
    bool fault_pending_ = false;  // a fault to enter at the next step (injected)
    uint16_t pending_error_ = 0;
};

}  // namespace irp::drivesim
