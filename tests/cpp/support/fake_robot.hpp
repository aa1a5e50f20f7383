// fake_robot.hpp -- the simulated robot of the PLC tests (test_plcopen.cpp, test_plcopen_motion.cpp,
// test_plc_program.cpp): it obeys the plc-robot cell's request/answer protocol (docs/plc.md) scan by
// scan, so that the function blocks and the pick-and-place program are tested without a robot
// module; scan() and runUntil() are the tests' periods.
#pragma once

#include <indurop/generated.h>  // cell.glb of config/sets/plc-robot
#include <indurop/plcopen/plcopen.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

using namespace plcopen;
using namespace std::chrono_literals;
using Service = PLC_ROBOT::ROBOT_MODULE_SERVICE_t;
using State = PLC_ROBOT::ROBOT_MODULE_STATE_t;
using Vec6 = std::array<double, kAxes>;

namespace plc_test {

struct Request {
    OpCode op;
    uint32_t seq;
    double speed;
    double accel;
    Vec6 target;
};

// The robot side of the contract, one run() per period (it runs before the PLC, as Robot.so has
// the higher priority): takes a request when nSeq != nAckSeq, answers in the state block.
class FakeRobot {
public:
    Service svc{};
    State st{};
    std::vector<Request> taken;  // every request taken, in order

    int powerCycles = 3;  // runs from taking a power request to its end
    int moveCycles = 5;   // runs of a move at speed 1 (scaled by 1 / t_speed)
    int stopCycles = 2;   // runs to standstill from a move
    int rampCycles = 3;   // runs of a velocity motion (op-code 7) until it holds its velocity
    int limitCycles = 0;  // then runs until a joint reaches its limit (ErrorID 2); 0: never
    bool powerOnTimesOut = false;
    bool resetFails = false;
    int resetBusyCycles = 0;  // a reset stays Busy (Error still 1) for this many runs
    std::function<bool(const Request &)> unreachable;

    FakeRobot() { st.nAXESGROUP = 6; }

    void run() {
        if (svc.nSeq != st.nAckSeq) {
            take();
            return;
        }
        if (remaining_ > 0 && --remaining_ == 0) finish();
    }

    void powerUp() {
        st.Powered = 1;
        st.eState = 1;
        st.MotionDone = 1;
    }
    // A drive fault: power lost, the group in error.
    void driveFault(int32_t id) {
        st.Powered = 0;
        refuse(id);
    }
    bool moving() const {
        return (remaining_ > 0 && (current_ == OpCode::MoveJ || current_ == OpCode::MoveL)) ||
               (current_ == OpCode::MoveVelocity && st.eState == 2);
    }
    // The motion vanishes without an answer, as when Robot.so is reloaded while moving.
    void dropMotion() {
        remaining_ = 0;
        st.Busy = 0;
        st.MotionDone = 1;
        st.eState = st.Powered ? 1 : 0;
    }
    OpCode lastOp() const { return taken.empty() ? OpCode::None : taken.back().op; }
    std::vector<OpCode> ops(std::size_t from = 0) const {
        std::vector<OpCode> v;
        for (std::size_t i = from; i < taken.size(); ++i) v.push_back(taken[i].op);
        return v;
    }

private:
    bool inError() const { return st.eState == 4; }
    void refuse(int32_t id) {
        st.Error = 1;
        st.ErrorID = id;
        st.eState = 4;
        st.Busy = 0;
        st.MotionDone = 0;
        remaining_ = 0;
    }
    void begin(int cycles) {
        st.Busy = 1;
        st.MotionDone = 0;
        remaining_ = cycles < 1 ? 1 : cycles;
    }
    void take() {
        Request r{static_cast<OpCode>(svc.eOpCode), svc.nSeq, svc.t_speed, svc.t_accel, {}};
        for (int i = 0; i < kAxes; ++i) r.target[i] = svc.dTarget[i];
        taken.push_back(r);
        st.nAckSeq = svc.nSeq;
        current_ = r.op;
        switch (r.op) {
        case OpCode::PowerOn:
            if (inError()) return refuse(st.ErrorID);
            return begin(powerCycles);
        case OpCode::PowerOff: return begin(powerCycles);
        case OpCode::MoveJ:
        case OpCode::MoveL:
            if (inError()) return refuse(st.ErrorID);
            if (!st.Powered) return refuse(1);
            if (unreachable && unreachable(r)) return refuse(r.op == OpCode::MoveJ ? 2 : 3);
            st.eState = 2;
            target_ = r.target;
            return begin(static_cast<int>(std::ceil(moveCycles / r.speed)));
        case OpCode::MoveVelocity:
            if (inError()) return refuse(st.ErrorID);
            if (!st.Powered) return refuse(1);
            st.eState = 2;
            inVelocity_ = false;
            return begin(rampCycles);
        case OpCode::Stop:
            if (inError()) return refuse(st.ErrorID);
            if (st.eState == 2) {
                st.eState = 3;
                return begin(stopCycles);
            }
            remaining_ = 0;
            st.Busy = 0;
            st.MotionDone = 1;
            return;
        case OpCode::Reset:
            if (!inError()) {
                remaining_ = 0;
                st.Busy = 0;
                st.MotionDone = 1;
                return;
            }
            if (resetBusyCycles > 0) {
                st.Busy = 1;
                remaining_ = resetBusyCycles;
                return;
            }
            return finishReset();
        default: return refuse(7);
        }
    }
    void finish() {
        switch (current_) {
        case OpCode::PowerOn:
            if (powerOnTimesOut) return refuse(6);
            st.Powered = 1;
            st.eState = 1;
            break;
        case OpCode::PowerOff:
            st.Powered = 0;
            if (!inError()) st.eState = 0;
            break;
        case OpCode::Reset: return finishReset();
        case OpCode::MoveVelocity:  // holds its velocity (Busy stays 1), until a joint reaches its limit
            if (inVelocity_) return refuse(2);
            inVelocity_ = true;
            st.MotionDone = 1;
            remaining_ = limitCycles;
            return;
        case OpCode::MoveJ:  // at the target, and the drives there
            for (int i = 0; i < kAxes; ++i) st.dCmdJoint[i] = st.dCurJoint[i] = target_[i];
            st.eState = 1;
            break;
        default: st.eState = 1; break;
        }
        st.Busy = 0;
        st.MotionDone = 1;
    }
    void finishReset() {
        if (resetFails) return refuse(st.ErrorID);
        st.Error = 0;
        st.ErrorID = 0;
        st.eState = st.Powered ? 1 : 0;
        st.Busy = 0;
        st.MotionDone = 1;
    }

    int remaining_ = 0;
    OpCode current_ = OpCode::None;
    Vec6 target_{};
    bool inVelocity_ = false;
};

// A robot and the axis group bound to it.  Not copyable: the group points into the robot.
struct Bench {
    FakeRobot robot;
    GroupStatus status;
    AxisGroupRef g = bindAxisGroup(robot.svc, robot.st, status);
    Bench() = default;
    Bench(const Bench &) = delete;
};

// One period of the PLC tests: the robot first (Robot.so has the higher priority), then the blocks
// in the order given (the PLC's scan).
template <class... Blocks>
void scan(Bench &b, Blocks &...blocks) {
    b.robot.run();
    (blocks(b.g), ...);
}

// Runs `period` until `done` holds, at most `max` periods; whether it holds then.
inline bool runUntil(const std::function<bool()> &done, const std::function<void()> &period, int max) {
    for (int i = 0; i < max && !done(); ++i) period();
    return done();
}

const Vec6 kJointTarget{0.1, -0.2, 0.3, -0.4, 0.5, -0.6};
const Vec6 kPoseTarget{0.4, 0.1, 0.3, 3.1, 0.0, 0.2};

}  // namespace plc_test
