// test_plcopen.cpp -- the PLC side of the plc-robot cell, scan by scan against a simulated robot
// that obeys the cell's request/answer protocol (docs/plc.md): every function block of
// indurop_plcopen through its state diagram, the IEC basics, the pick-and-place POU of
// config/sets/plc-robot/POUS.h through its whole cycle, and main.so itself through the
// production loader on a real shared-variable segment of cell.glb.
#include "POUS.h"

#include "hosts/thread_module.hpp"
#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"

#include <indurop/generated.h>  // cell.glb of config/sets/plc-robot
#include <plcopen/plcopen.h>

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <unistd.h>
#include <vector>

using namespace plcopen;
using namespace std::chrono_literals;
using Service = PLC_ROBOT::ROBOT_MODULE_SERVICE_t;
using State = PLC_ROBOT::ROBOT_MODULE_STATE_t;
using Vec6 = std::array<double, kAxes>;

namespace {

// ---- the simulated robot -----------------------------------------------------------------------

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
    bool moving() const { return remaining_ > 0 && (current_ == OpCode::MoveJ || current_ == OpCode::MoveL); }
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
            return begin(static_cast<int>(std::ceil(moveCycles / r.speed)));
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
};

// A robot and the axis group bound to it.  Not copyable: the group points into the robot.
struct Bench {
    FakeRobot robot;
    AxisGroupRef g = bindAxisGroup(robot.svc, robot.st);
    Bench() = default;
    Bench(const Bench &) = delete;
};

const Vec6 kJointTarget{0.1, -0.2, 0.3, -0.4, 0.5, -0.6};
const Vec6 kPoseTarget{0.4, 0.1, 0.3, 3.1, 0.0, 0.2};

// ---- MC_MoveAbsolute / MC_MoveLinear -------------------------------------------------------------

TEST(MoveAbsolute, RequestsOnTheRisingEdgeIsActiveWhenTakenAndDoneWhenTheRobotFinishes) {
    Bench b;
    b.robot.powerUp();
    b.robot.moveCycles = 4;  // at Velocity 0.5: 8 runs
    MC_MoveAbsolute mv;
    mv.Position = kJointTarget;
    mv.Velocity = 0.5;
    mv.Acceleration = 0.25;

    b.robot.run();
    mv(b.g);  // Execute FALSE: nothing
    EXPECT_FALSE(mv.Busy || mv.Active || mv.Done || mv.Error || mv.CommandAborted);
    EXPECT_EQ(b.robot.svc.nSeq, 0u);

    mv.Execute = true;  // the rising edge writes the request, nSeq last
    b.robot.run();
    mv(b.g);
    EXPECT_TRUE(mv.Busy);
    EXPECT_FALSE(mv.Active) << "not taken by the robot yet";
    EXPECT_FALSE(mv.Done);
    EXPECT_EQ(b.robot.svc.nSeq, 1u);
    EXPECT_EQ(b.robot.svc.eOpCode, 3);
    EXPECT_DOUBLE_EQ(b.robot.svc.t_speed, 0.5);
    EXPECT_DOUBLE_EQ(b.robot.svc.t_accel, 0.25);
    for (int i = 0; i < kAxes; ++i) EXPECT_DOUBLE_EQ(b.robot.svc.dTarget[i], kJointTarget[i]);

    b.robot.run();  // takes it
    mv(b.g);
    EXPECT_TRUE(mv.Busy && mv.Active);
    ASSERT_EQ(b.robot.taken.size(), 1u);
    for (int run = 1; run < 8; ++run) {
        b.robot.run();
        mv(b.g);
        EXPECT_TRUE(mv.Busy && mv.Active && !mv.Done) << "run " << run;
    }
    b.robot.run();  // the 8th run ends the move: MotionDone for nAckSeq 1
    mv(b.g);
    EXPECT_TRUE(mv.Done);
    EXPECT_FALSE(mv.Busy || mv.Active || mv.Error || mv.CommandAborted);

    for (int scan = 0; scan < 5; ++scan) {  // Done stays while Execute stays TRUE
        b.robot.run();
        mv(b.g);
        EXPECT_TRUE(mv.Done) << scan;
    }
    mv.Execute = false;  // and resets with it
    b.robot.run();
    mv(b.g);
    EXPECT_FALSE(mv.Done || mv.Busy);
    EXPECT_EQ(b.robot.taken.size(), 1u) << "one request per rising edge";
}

TEST(MoveAbsolute, ExecuteFallingWhileBusyLetsTheMoveFinishAndShowsDoneForOneScan) {
    Bench b;
    b.robot.powerUp();
    MC_MoveAbsolute mv;
    mv.Position = kJointTarget;
    mv.Execute = true;
    b.robot.run();
    mv(b.g);
    mv.Execute = false;  // falls while busy
    int scans = 0;
    while (!mv.Done && scans < 100) {
        EXPECT_TRUE(mv.Busy) << "the command goes on after Execute fell";
        b.robot.run();
        mv(b.g);
        ++scans;
    }
    ASSERT_TRUE(mv.Done);
    EXPECT_FALSE(mv.Busy);
    b.robot.run();
    mv(b.g);
    EXPECT_FALSE(mv.Done) << "shown for exactly one scan";
    EXPECT_EQ(b.robot.taken.size(), 1u);
}

TEST(MoveAbsolute, RisingEdgeWhileBusyStartsANewMoveAndTheFirstGetsNoFeedback) {
    Bench b;
    b.robot.powerUp();
    MC_MoveAbsolute mv;
    mv.Position = kJointTarget;
    mv.Execute = true;
    b.robot.run();
    mv(b.g);
    b.robot.run();
    mv(b.g);
    ASSERT_TRUE(mv.Active);
    mv.Execute = false;
    b.robot.run();
    mv(b.g);
    mv.Execute = true;  // a new edge while busy
    mv.Position = Vec6{1, 1, 1, 1, 1, 1};
    b.robot.run();
    mv(b.g);
    EXPECT_EQ(b.robot.svc.nSeq, 2u);
    for (int scan = 0; scan < 100 && !mv.Done; ++scan) {
        EXPECT_FALSE(mv.CommandAborted || mv.Error) << "the superseded command of the same instance is silent";
        EXPECT_TRUE(mv.Busy);
        b.robot.run();
        mv(b.g);
    }
    ASSERT_TRUE(mv.Done);
    ASSERT_EQ(b.robot.taken.size(), 2u);
    EXPECT_DOUBLE_EQ(b.robot.taken[1].target[0], 1.0);
}

TEST(MoveLinear, ANewerMoveAbortsTheRunningOneWithCommandAborted) {
    Bench b;
    b.robot.powerUp();
    MC_MoveAbsolute first;
    MC_MoveLinear second;
    first.Position = kJointTarget;
    second.Position = kPoseTarget;
    second.Velocity = 0.25;
    first.Execute = true;
    b.robot.run();
    first(b.g);
    second(b.g);
    b.robot.run();
    first(b.g);
    second(b.g);
    ASSERT_TRUE(first.Active);

    second.Execute = true;  // called after `first` in the scan
    b.robot.run();
    first(b.g);
    second(b.g);
    EXPECT_TRUE(first.Busy && first.Active) << "the first learns of it in its next call";
    EXPECT_TRUE(second.Busy);
    EXPECT_EQ(b.robot.svc.eOpCode, 4);

    b.robot.run();  // takes the MoveL, replacing the MoveJ
    first(b.g);
    second(b.g);
    EXPECT_TRUE(first.CommandAborted);
    EXPECT_FALSE(first.Busy || first.Active || first.Done || first.Error);
    EXPECT_TRUE(second.Busy && second.Active);

    for (int scan = 0; scan < 100 && !second.Done; ++scan) {
        b.robot.run();
        first(b.g);
        second(b.g);
        EXPECT_TRUE(first.CommandAborted) << "stays while Execute stays TRUE";
        EXPECT_FALSE(first.Done);
    }
    EXPECT_TRUE(second.Done);
    first.Execute = false;
    b.robot.run();
    first(b.g);
    EXPECT_FALSE(first.CommandAborted);
    ASSERT_EQ(b.robot.ops(), (std::vector<OpCode>{OpCode::MoveJ, OpCode::MoveL}));
    EXPECT_DOUBLE_EQ(b.robot.taken[1].speed, 0.25);
    for (int i = 0; i < kAxes; ++i) EXPECT_DOUBLE_EQ(b.robot.taken[1].target[i], kPoseTarget[i]);
}

TEST(MoveLinear, ARefusedRequestIsErrorWithTheRobotsErrorID) {
    Bench b;
    b.robot.powerUp();
    b.robot.unreachable = [](const Request &r) { return r.op == OpCode::MoveL; };
    MC_MoveLinear mv;
    mv.Position = kPoseTarget;
    mv.Execute = true;
    b.robot.run();
    mv(b.g);
    EXPECT_TRUE(mv.Busy);
    b.robot.run();  // refuses: ErrorID 3, unreachable
    mv(b.g);
    EXPECT_TRUE(mv.Error);
    EXPECT_EQ(mv.ErrorID, 3);
    EXPECT_FALSE(mv.Busy || mv.Active || mv.Done || mv.CommandAborted);
    for (int scan = 0; scan < 3; ++scan) {
        b.robot.run();
        mv(b.g);
        EXPECT_TRUE(mv.Error && mv.ErrorID == 3);
    }
    mv.Execute = false;
    b.robot.run();
    mv(b.g);
    EXPECT_FALSE(mv.Error);
    EXPECT_EQ(mv.ErrorID, 0);
}

TEST(MoveAbsolute, AMoveOnAnUnpoweredRobotFailsWithErrorID1) {
    Bench b;
    MC_MoveAbsolute mv;
    mv.Execute = true;
    b.robot.run();
    mv(b.g);
    b.robot.run();
    mv(b.g);
    EXPECT_TRUE(mv.Error);
    EXPECT_EQ(mv.ErrorID, 1);
}

TEST(MoveAbsolute, AnErrorWhileMovingComesFromTheRobotsState) {
    Bench b;
    b.robot.powerUp();
    MC_MoveAbsolute mv;
    mv.Execute = true;
    b.robot.run();
    mv(b.g);
    b.robot.run();
    mv(b.g);
    ASSERT_TRUE(mv.Active);
    b.robot.driveFault(4);
    b.robot.run();
    mv(b.g);
    EXPECT_TRUE(mv.Error);
    EXPECT_EQ(mv.ErrorID, 4);
    EXPECT_FALSE(mv.Busy || mv.Active);
}

TEST(MoveAbsolute, BadParametersFailAtOnceWithoutARequest) {
    Bench b;
    b.robot.powerUp();
    auto attempt = [&](auto setup) {
        MC_MoveAbsolute mv;
        setup(mv);
        mv.Execute = true;
        const uint32_t before = b.robot.svc.nSeq;
        mv(b.g);
        EXPECT_EQ(b.robot.svc.nSeq, before) << "no request written";
        return std::make_pair(mv.Error, mv.ErrorID);
    };
    const auto invalid = std::make_pair(true, error::kInvalidParameter);
    EXPECT_EQ(attempt([](MC_MoveAbsolute &m) { m.Velocity = 0; }), invalid);
    EXPECT_EQ(attempt([](MC_MoveAbsolute &m) { m.Velocity = 1.5; }), invalid);
    EXPECT_EQ(attempt([](MC_MoveAbsolute &m) { m.Acceleration = -1; }), invalid);
    EXPECT_EQ(attempt([](MC_MoveAbsolute &m) { m.Position[3] = std::numeric_limits<double>::quiet_NaN(); }), invalid);
    EXPECT_EQ(attempt([](MC_MoveAbsolute &m) { m.Velocity = std::numeric_limits<double>::infinity(); }), invalid);

    AxisGroupRef unbound;
    MC_MoveLinear mv;
    mv.Execute = true;
    mv(unbound);
    EXPECT_TRUE(mv.Error);
    EXPECT_EQ(mv.ErrorID, error::kNotBound);
}

TEST(MoveAbsolute, SequenceNumbersWrapAround) {
    EXPECT_TRUE(seqAfter(0u, 0xFFFFFFFFu));
    EXPECT_FALSE(seqAfter(0xFFFFFFFFu, 0u));
    EXPECT_FALSE(seqAfter(5u, 5u));
    Bench b;
    b.robot.powerUp();
    b.robot.svc.nSeq = b.robot.st.nAckSeq = 0xFFFFFFFEu;
    MC_MoveAbsolute first, second;
    first.Execute = true;
    b.robot.run();
    first(b.g);
    EXPECT_EQ(b.robot.svc.nSeq, 0xFFFFFFFFu);
    b.robot.run();
    first(b.g);
    second.Execute = true;
    second(b.g);
    EXPECT_EQ(b.robot.svc.nSeq, 0u);
    b.robot.run();
    first(b.g);
    second(b.g);
    EXPECT_TRUE(first.CommandAborted) << "0 comes after 0xFFFFFFFF";
    EXPECT_TRUE(second.Active);
    for (int scan = 0; scan < 100 && !second.Done; ++scan) {
        b.robot.run();
        second(b.g);
    }
    EXPECT_TRUE(second.Done);
}

// ---- MC_Power ----------------------------------------------------------------------------------

TEST(Power, EnablePowersOnAndStatusFollowsTheRobot) {
    Bench b;
    MC_Power pw;
    b.robot.run();
    pw(b.g);
    EXPECT_FALSE(pw.Status || pw.Valid || pw.Busy || pw.Error);
    EXPECT_EQ(b.robot.svc.nSeq, 0u);

    pw.Enable = true;
    b.robot.run();
    pw(b.g);
    EXPECT_TRUE(pw.Busy);
    EXPECT_TRUE(pw.Valid);
    EXPECT_FALSE(pw.Status);
    EXPECT_EQ(b.robot.svc.eOpCode, 1);
    int scans = 0;
    while (!pw.Status && scans < 20) {
        b.robot.run();
        pw(b.g);
        ++scans;
    }
    EXPECT_TRUE(pw.Status);
    EXPECT_EQ(scans, 1 + b.robot.powerCycles) << "taken, then powerCycles runs";
    EXPECT_FALSE(pw.Busy);
    EXPECT_TRUE(pw.Valid);
    for (int scan = 0; scan < 5; ++scan) {
        b.robot.run();
        pw(b.g);
    }
    EXPECT_EQ(b.robot.taken.size(), 1u) << "no more requests while enabled and powered";

    pw.Enable = false;
    b.robot.run();
    pw(b.g);
    EXPECT_EQ(b.robot.svc.eOpCode, 2);
    EXPECT_FALSE(pw.Valid);
    for (int scan = 0; scan < 20 && pw.Status; ++scan) {
        b.robot.run();
        pw(b.g);
    }
    EXPECT_FALSE(pw.Status || pw.Busy || pw.Error);
    EXPECT_EQ(b.robot.ops(), (std::vector<OpCode>{OpCode::PowerOn, OpCode::PowerOff}));
}

TEST(Power, EnablingAPoweredRobotSendsNothing) {
    Bench b;
    b.robot.powerUp();
    MC_Power pw;
    pw.Enable = true;
    b.robot.run();
    pw(b.g);
    EXPECT_TRUE(pw.Status && pw.Valid);
    EXPECT_FALSE(pw.Busy);
    EXPECT_EQ(b.robot.svc.nSeq, 0u);
}

TEST(Power, APowerOnTimeoutIsAnErrorUntilEnableFalls) {
    Bench b;
    b.robot.powerOnTimesOut = true;
    MC_Power pw;
    pw.Enable = true;
    for (int scan = 0; scan < 20 && !pw.Error; ++scan) {
        b.robot.run();
        pw(b.g);
    }
    EXPECT_TRUE(pw.Error);
    EXPECT_EQ(pw.ErrorID, 6);
    EXPECT_FALSE(pw.Valid || pw.Status || pw.Busy);
    for (int scan = 0; scan < 5; ++scan) {
        b.robot.run();
        pw(b.g);
        EXPECT_TRUE(pw.Error);
    }
    EXPECT_EQ(b.robot.ops(), (std::vector<OpCode>{OpCode::PowerOn})) << "no retry while the group is in error";
    pw.Enable = false;
    b.robot.run();
    pw(b.g);
    EXPECT_FALSE(pw.Error);
    EXPECT_EQ(pw.ErrorID, 0);
}

TEST(Power, PowerLostIsAnErrorAndAfterResetThePowerComesBack) {
    Bench b;
    MC_Power pw;
    MC_Reset rs;
    pw.Enable = true;
    for (int scan = 0; scan < 20 && !pw.Status; ++scan) {
        b.robot.run();
        pw(b.g);
        rs(b.g);
    }
    ASSERT_TRUE(pw.Status);
    b.robot.driveFault(4);
    b.robot.run();
    pw(b.g);
    rs(b.g);
    EXPECT_TRUE(pw.Error);
    EXPECT_EQ(pw.ErrorID, 4);
    EXPECT_FALSE(pw.Status || pw.Valid);

    rs.Execute = true;
    for (int scan = 0; scan < 20 && !(pw.Status && rs.Done); ++scan) {
        b.robot.run();
        pw(b.g);
        rs(b.g);
        EXPECT_FALSE(rs.Error);
    }
    EXPECT_TRUE(rs.Done);
    EXPECT_TRUE(pw.Status) << "powered again: Enable stayed TRUE";
    EXPECT_FALSE(pw.Error);
    EXPECT_TRUE(pw.Valid);
    EXPECT_EQ(b.robot.ops(), (std::vector<OpCode>{OpCode::PowerOn, OpCode::Reset, OpCode::PowerOn}));
}

TEST(Power, DisablingAbortsTheRunningMove) {
    Bench b;
    b.robot.powerUp();
    MC_Power pw;
    MC_MoveAbsolute mv;
    pw.Enable = mv.Execute = true;
    b.robot.run();
    pw(b.g);
    mv(b.g);
    b.robot.run();
    pw(b.g);
    mv(b.g);
    ASSERT_TRUE(mv.Active);
    pw.Enable = false;
    b.robot.run();
    pw(b.g);
    mv(b.g);
    EXPECT_TRUE(mv.CommandAborted);
    EXPECT_FALSE(mv.Busy);
}

// ---- MC_Stop -----------------------------------------------------------------------------------

TEST(Stop, StopsTheMoveHoldsTheGroupWhileExecuteAndReleasesIt) {
    Bench b;
    b.robot.powerUp();
    MC_MoveAbsolute mv;
    MC_Stop st;
    mv.Execute = true;
    b.robot.run();
    mv(b.g);
    st(b.g);
    b.robot.run();
    mv(b.g);
    st(b.g);
    ASSERT_TRUE(mv.Active);

    st.Execute = true;
    b.robot.run();
    mv(b.g);
    st(b.g);
    EXPECT_TRUE(st.Busy);
    EXPECT_EQ(b.robot.svc.eOpCode, 5);
    b.robot.run();  // takes the stop
    mv(b.g);
    st(b.g);
    EXPECT_TRUE(mv.CommandAborted);
    EXPECT_TRUE(st.Busy);
    EXPECT_EQ(b.robot.st.eState, 3) << "stopping";
    int scans = 0;
    while (!st.Done && scans < 20) {
        b.robot.run();
        mv(b.g);
        st(b.g);
        ++scans;
    }
    EXPECT_TRUE(st.Done);
    EXPECT_EQ(scans, b.robot.stopCycles);
    EXPECT_FALSE(st.Busy || st.Error);
    EXPECT_EQ(b.robot.st.eState, 1);

    // While Stop's Execute is TRUE the group refuses motion.
    MC_MoveLinear other;
    other.Execute = true;
    const uint32_t before = b.robot.svc.nSeq;
    b.robot.run();
    st(b.g);
    other(b.g);
    EXPECT_TRUE(other.Error);
    EXPECT_EQ(other.ErrorID, error::kGroupStopping);
    EXPECT_EQ(b.robot.svc.nSeq, before);
    EXPECT_TRUE(st.Done);

    st.Execute = false;
    other.Execute = false;
    b.robot.run();
    st(b.g);
    other(b.g);
    EXPECT_FALSE(st.Done);
    other.Execute = true;  // released: moves again
    b.robot.run();
    st(b.g);
    other(b.g);
    EXPECT_TRUE(other.Busy);
    EXPECT_FALSE(other.Error);
    EXPECT_EQ(b.robot.svc.eOpCode, 4);
}

TEST(Stop, ExecuteFallingWhileStoppingHoldsUntilStandstillAndShowsDoneOnce) {
    Bench b;
    b.robot.powerUp();
    b.robot.stopCycles = 4;
    MC_MoveAbsolute mv;
    MC_Stop st;
    mv.Execute = true;
    b.robot.run();
    mv(b.g);
    b.robot.run();
    mv(b.g);
    st.Execute = true;
    b.robot.run();
    st(b.g);
    st.Execute = false;  // falls at once
    MC_MoveAbsolute next;
    next.Execute = true;
    b.robot.run();
    st(b.g);
    next(b.g);
    EXPECT_TRUE(st.Busy);
    EXPECT_TRUE(next.Error) << "still stopping";
    EXPECT_EQ(next.ErrorID, error::kGroupStopping);
    while (!st.Done && st.Busy) {
        b.robot.run();
        st(b.g);
    }
    EXPECT_TRUE(st.Done);
    b.robot.run();
    st(b.g);
    EXPECT_FALSE(st.Done) << "shown for one scan";
    next.Execute = false;
    next(b.g);
    next.Execute = true;
    next(b.g);
    EXPECT_TRUE(next.Busy && !next.Error) << "the group is free again";
}

// ---- MC_Reset ----------------------------------------------------------------------------------

TEST(Reset, ClearsTheGroupsError) {
    Bench b;
    b.robot.powerUp();
    b.robot.unreachable = [](const Request &) { return true; };
    MC_MoveAbsolute mv;
    MC_Reset rs;
    mv.Execute = true;
    b.robot.run();
    mv(b.g);
    b.robot.run();
    mv(b.g);
    ASSERT_TRUE(mv.Error);
    ASSERT_EQ(b.robot.st.eState, 4);

    rs.Execute = true;
    b.robot.run();
    rs(b.g);
    EXPECT_TRUE(rs.Busy);
    EXPECT_EQ(b.robot.svc.eOpCode, 6);
    b.robot.run();
    rs(b.g);
    EXPECT_TRUE(rs.Done);
    EXPECT_FALSE(rs.Busy || rs.Error);
    EXPECT_EQ(b.robot.st.Error, 0);
    EXPECT_EQ(b.robot.st.eState, 1);
    rs.Execute = false;
    b.robot.run();
    rs(b.g);
    EXPECT_FALSE(rs.Done);
}

TEST(Reset, WithoutAnErrorItIsDoneAtOnceAndSendsNothing) {
    Bench b;
    b.robot.powerUp();
    MC_MoveAbsolute mv;
    MC_Reset rs;
    mv.Execute = true;
    b.robot.run();
    mv(b.g);
    rs(b.g);
    rs.Execute = true;
    b.robot.run();
    mv(b.g);
    rs(b.g);
    EXPECT_TRUE(rs.Done);
    EXPECT_FALSE(rs.Busy);
    EXPECT_EQ(b.robot.ops(), (std::vector<OpCode>{OpCode::MoveJ}));
    EXPECT_TRUE(mv.Active) << "a reset never aborts a running move";
}

TEST(Reset, ErrorStillSetWhileTheRobotIsBusyResettingIsNotAFailure) {
    Bench b;
    b.robot.driveFault(4);
    b.robot.resetBusyCycles = 3;
    MC_Reset rs;
    rs.Execute = true;
    b.robot.run();
    rs(b.g);
    for (int scan = 0; scan < 3; ++scan) {
        b.robot.run();
        rs(b.g);
        EXPECT_TRUE(rs.Busy) << scan;
        EXPECT_FALSE(rs.Error) << scan;
    }
    b.robot.run();
    rs(b.g);
    EXPECT_TRUE(rs.Done);
    EXPECT_EQ(b.robot.st.eState, 0) << "unpowered: disabled after the reset";
}

TEST(Reset, ARefusedResetIsAnError) {
    Bench b;
    b.robot.driveFault(4);
    b.robot.resetFails = true;
    MC_Reset rs;
    rs.Execute = true;
    b.robot.run();
    rs(b.g);
    b.robot.run();
    rs(b.g);
    EXPECT_TRUE(rs.Error);
    EXPECT_EQ(rs.ErrorID, 4);
    EXPECT_FALSE(rs.Done || rs.Busy);
}

// ---- MC_GroupReadError -------------------------------------------------------------------------

TEST(GroupReadError, ShowsTheRobotsErrorWhileEnabled) {
    Bench b;
    MC_GroupReadError re;
    re(b.g);
    EXPECT_FALSE(re.Valid);
    re.Enable = true;
    re(b.g);
    EXPECT_TRUE(re.Valid);
    EXPECT_EQ(re.GroupErrorID, 0);
    b.robot.driveFault(8);
    re(b.g);
    EXPECT_EQ(re.GroupErrorID, 8);
    EXPECT_FALSE(re.Error) << "the block itself is fine";
    AxisGroupRef unbound;
    re(unbound);
    EXPECT_TRUE(re.Error);
    EXPECT_EQ(re.ErrorID, error::kNotBound);
}

// ---- IEC basics --------------------------------------------------------------------------------

TEST(Iec, R_TRIG_IsTrueForOneCallOnEachRisingEdge) {
    R_TRIG t;
    std::vector<bool> q;
    for (bool clk : {false, true, true, false, true, false, false}) q.push_back(t(clk));
    EXPECT_EQ(q, (std::vector<bool>{false, true, false, false, true, false, false}));
    R_TRIG first;
    EXPECT_TRUE(first(true)) << "M starts FALSE: a TRUE first call is an edge (IEC 61131-3)";
}

TEST(Iec, F_TRIG_IsTrueForOneCallOnEachFallingEdge) {
    F_TRIG t;
    std::vector<bool> q;
    for (bool clk : {false, true, true, false, false, true, false}) q.push_back(t(clk));
    EXPECT_EQ(q, (std::vector<bool>{false, false, false, true, false, false, true}));
}

TEST(Iec, TON_DelaysTheRisingEdgeByPT) {
    TON t;
    t.PT = 30ms;
    Time now{1'000'000'000};
    auto step = [&](bool in) {
        t.IN = in;
        t(now);
        now += 10ms;
        return t.Q;
    };
    EXPECT_FALSE(step(false));
    EXPECT_FALSE(step(true));
    EXPECT_EQ(t.ET, 0ms);
    EXPECT_FALSE(step(true));
    EXPECT_EQ(t.ET, 10ms);
    EXPECT_FALSE(step(true));
    EXPECT_TRUE(step(true)) << "30 ms after IN rose";
    EXPECT_EQ(t.ET, 30ms);
    EXPECT_TRUE(step(true));
    EXPECT_EQ(t.ET, 30ms) << "ET stops at PT";
    EXPECT_FALSE(step(false)) << "IN FALSE resets at once";
    EXPECT_EQ(t.ET, 0ms);
    EXPECT_FALSE(step(true)) << "and the delay starts again";
    TON zero;
    EXPECT_TRUE(zero(true, 0ms, now)) << "PT 0: Q follows IN";
}

// ---- the pick-and-place program (POUS.h) --------------------------------------------------------

pou::Settings testSettings() {
    pou::Settings s;
    s.home = {0.0, -0.5, 1.0, 0.0, 0.5, 0.0};
    s.pick_above = {0.5, -0.3, 1.1, 0.0, 0.8, 0.0};
    s.pick = {0.45, 0.25, 0.15, 3.14, 0.0, 0.0};
    s.place_above = {-0.5, -0.3, 1.1, 0.0, 0.8, 0.0};
    s.place = {0.45, -0.25, 0.15, 3.14, 0.0, 0.0};
    s.lift = 0.1;
    s.joint_speed = 0.5;
    s.linear_speed = 0.25;
    s.accel = 0.4;
    s.dwell = 50ms;
    return s;
}

class Program : public ::testing::Test {
protected:
    static constexpr Time kPeriod = 10ms;

    void SetUp() override { program = std::make_unique<pou::PickAndPlace>(settings); }

    // One period: the robot (priority 2), then the PLC scan (priority 3).
    void period() {
        robot.run();
        scanTime = now;
        program->scan(in, out, g, now);
        now += kPeriod;
        EXPECT_EQ(out.O0, robot.st.MotionDone != 0) << "O0 is the robot's MotionDone";
        EXPECT_EQ(out.Running, out.Step != 0);
        if (steps.empty() || steps.back() != out.Step) steps.push_back(out.Step);
    }
    bool runUntil(const std::function<bool()> &done, int max = 5000) {
        for (int i = 0; i < max; ++i) {
            if (done()) return true;
            period();
        }
        return done();
    }
    void pulse(bool pou::Inputs::*input) {
        in.*input = true;
        period();
        in.*input = false;
    }
    void powerOn() {
        in.Enable = true;
        ASSERT_TRUE(runUntil([&] { return out.Powered; }));
    }
    // The moves the robot took since request `from`.
    std::vector<Request> moves(std::size_t from = 0) const {
        std::vector<Request> v;
        for (std::size_t i = from; i < robot.taken.size(); ++i)
            if (robot.taken[i].op == OpCode::MoveJ || robot.taken[i].op == OpCode::MoveL) v.push_back(robot.taken[i]);
        return v;
    }

    pou::Settings settings = testSettings();
    FakeRobot robot;
    AxisGroupRef g = bindAxisGroup(robot.svc, robot.st);
    std::unique_ptr<pou::PickAndPlace> program;
    pou::Inputs in;
    pou::Outputs out;
    Time now{5'000'000'000};
    Time scanTime{0};
    std::vector<int32_t> steps;  // the distinct values of PLC_OUT.Step, in order
};

const std::vector<int32_t> kOneCycle{1, 2, 3, 4, 5, 6, 7, 8, 0};

TEST_F(Program, StartRunsTheWholeCycleThroughEveryStepInOrder) {
    powerOn();
    EXPECT_EQ(robot.ops(), (std::vector<OpCode>{OpCode::PowerOn}));
    const std::size_t before = robot.taken.size();
    steps.clear();
    pulse(&pou::Inputs::I0);
    EXPECT_EQ(out.Step, 1);
    EXPECT_TRUE(out.Running);
    ASSERT_TRUE(runUntil([&] { return !out.Running; }));
    EXPECT_EQ(steps, kOneCycle);
    EXPECT_TRUE(out.Done);
    EXPECT_EQ(out.Cycles, 1u);
    EXPECT_FALSE(out.Error);
    EXPECT_EQ(out.ErrorID, 0);

    const auto m = moves(before);
    ASSERT_EQ(m.size(), 8u);
    const std::vector<OpCode> ops{OpCode::MoveJ, OpCode::MoveJ, OpCode::MoveL, OpCode::MoveL,
                                  OpCode::MoveJ, OpCode::MoveL, OpCode::MoveL, OpCode::MoveJ};
    Vec6 pickUp = settings.pick, placeUp = settings.place;
    pickUp[2] += settings.lift;
    placeUp[2] += settings.lift;
    const std::vector<Vec6> targets{settings.home,        settings.pick_above, settings.pick, pickUp,
                                    settings.place_above, settings.place,      placeUp,       settings.home};
    for (std::size_t i = 0; i < m.size(); ++i) {
        EXPECT_EQ(m[i].op, ops[i]) << "step " << i + 1;
        for (int k = 0; k < kAxes; ++k) EXPECT_DOUBLE_EQ(m[i].target[k], targets[i][k]) << "step " << i + 1;
        EXPECT_DOUBLE_EQ(m[i].speed, m[i].op == OpCode::MoveJ ? settings.joint_speed : settings.linear_speed);
        EXPECT_DOUBLE_EQ(m[i].accel, settings.accel);
    }
    EXPECT_EQ(robot.taken.size(), before + 8) << "nothing but the eight moves";
    for (int i = 0; i < 20; ++i) period();
    EXPECT_EQ(out.Step, 0) << "CycleMode 0: one cycle per Start";
    EXPECT_TRUE(out.Done) << "Done stays until the next Start";
}

TEST_F(Program, EachStepWaitsForTheRobotAndPickAndPlaceDwell) {
    powerOn();
    pulse(&pou::Inputs::Start);  // PLC_IN.Start works like I0
    ASSERT_EQ(out.Step, 1);
    // Step 1 lasts while the robot runs the MoveJ home.
    ASSERT_TRUE(runUntil([&] { return robot.st.nAckSeq == robot.svc.nSeq && robot.st.Busy; }));
    while (robot.st.Busy) {
        EXPECT_EQ(out.Step, 1);
        period();
    }
    EXPECT_EQ(out.Step, 2) << "the scan that sees MotionDone moves on";

    ASSERT_TRUE(runUntil([&] { return program->MoveL_PickDown.Done; }));
    const Time reached = scanTime;
    EXPECT_EQ(out.Step, 3);
    ASSERT_TRUE(runUntil([&] { return out.Step == 4; }));
    EXPECT_EQ(scanTime - reached, settings.dwell) << "the gripper's dwell at the pick pose";
    ASSERT_TRUE(runUntil([&] { return program->MoveL_PlaceDown.Done; }));
    const Time placed = scanTime;
    ASSERT_TRUE(runUntil([&] { return out.Step == 7; }));
    EXPECT_EQ(scanTime - placed, settings.dwell);
    ASSERT_TRUE(runUntil([&] { return !out.Running; }));
    EXPECT_EQ(out.Cycles, 1u);
}

TEST_F(Program, StartIsIgnoredUnpoweredWhileStoppedAndWhileRunning) {
    pulse(&pou::Inputs::I0);  // not enabled
    for (int i = 0; i < 10; ++i) period();
    EXPECT_EQ(out.Step, 0);
    EXPECT_TRUE(robot.taken.empty());

    powerOn();
    in.I1 = true;  // Stop held
    period();
    pulse(&pou::Inputs::I0);
    for (int i = 0; i < 10; ++i) period();
    EXPECT_EQ(out.Step, 0);
    EXPECT_TRUE(moves().empty());
    in.I1 = false;
    period();

    pulse(&pou::Inputs::I0);
    ASSERT_TRUE(runUntil([&] { return out.Step == 3; }));
    const uint32_t requested = robot.svc.nSeq;
    pulse(&pou::Inputs::I0);  // a second Start during the cycle
    EXPECT_EQ(out.Step, 3);
    EXPECT_EQ(robot.svc.nSeq, requested) << "no new request";
    ASSERT_TRUE(runUntil([&] { return !out.Running; }));
    EXPECT_EQ(out.Cycles, 1u);
}

TEST_F(Program, AStartHeldWhenTheProgramBeginsIsNoEdge) {
    robot.powerUp();  // e.g. main.so reloaded while the robot is powered and Start is held
    in.Enable = true;
    in.I0 = true;
    for (int i = 0; i < 10; ++i) period();
    EXPECT_EQ(out.Step, 0);
    EXPECT_TRUE(robot.taken.empty()) << "powered already: MC_Power sends nothing either";
    in.I0 = false;
    period();
    pulse(&pou::Inputs::I0);
    EXPECT_EQ(out.Step, 1);
}

TEST_F(Program, StopAbortsTheCycleAndStopsTheRobot) {
    powerOn();
    pulse(&pou::Inputs::I0);
    ASSERT_TRUE(runUntil([&] { return out.Step == 3 && robot.moving(); }));
    in.I1 = true;
    period();
    EXPECT_EQ(out.Step, 0) << "the cycle ends in the scan that sees Stop";
    EXPECT_FALSE(out.Running);
    EXPECT_EQ(robot.svc.eOpCode, 5) << "MC_Stop's request";
    EXPECT_TRUE(program->MoveL_PickDown.CommandAborted) << "shown once: its Execute fell with the step";
    period();
    EXPECT_FALSE(program->MoveL_PickDown.CommandAborted);
    EXPECT_EQ(robot.lastOp(), OpCode::Stop);
    EXPECT_EQ(robot.st.eState, 3);
    ASSERT_TRUE(runUntil([&] { return program->StopRobot.Done; }));
    EXPECT_EQ(robot.st.eState, 1) << "standstill";
    EXPECT_FALSE(out.Done);
    EXPECT_FALSE(out.Error);
    EXPECT_EQ(out.Cycles, 0u);
    const std::size_t taken = robot.taken.size();
    for (int i = 0; i < 20; ++i) period();
    EXPECT_EQ(robot.taken.size(), taken) << "stays stopped while Stop is held";

    in.I1 = false;
    period();
    steps.clear();
    pulse(&pou::Inputs::I0);  // starts again from step 1
    ASSERT_TRUE(runUntil([&] { return !out.Running; }));
    EXPECT_EQ(steps, kOneCycle);
    EXPECT_EQ(out.Cycles, 1u);

    // PLC_IN.Stop is the same as I1.
    pulse(&pou::Inputs::Start);
    ASSERT_TRUE(runUntil([&] { return out.Step == 5; }));
    in.Stop = true;
    period();
    EXPECT_EQ(out.Step, 0);
    ASSERT_TRUE(runUntil([&] { return program->StopRobot.Done; }));
    EXPECT_EQ(out.Cycles, 1u);
}

TEST_F(Program, CycleModeOneRepeatsUntilStop) {
    powerOn();
    in.CycleMode = 1;
    steps.clear();
    pulse(&pou::Inputs::I0);
    ASSERT_TRUE(runUntil([&] { return out.Cycles == 3; }));
    EXPECT_TRUE(out.Running);
    EXPECT_TRUE(out.Done);
    std::vector<int32_t> three;
    for (int c = 0; c < 3; ++c) three.insert(three.end(), kOneCycle.begin(), kOneCycle.end() - 1);
    three.push_back(1);
    ASSERT_GE(steps.size(), three.size());
    EXPECT_EQ(std::vector<int32_t>(steps.begin(), steps.begin() + three.size()), three)
        << "every cycle through every step, back to step 1";
    in.I1 = true;
    period();
    EXPECT_FALSE(out.Running);
    for (int i = 0; i < 100; ++i) period();
    EXPECT_EQ(out.Cycles, 3u);
    EXPECT_EQ(out.Step, 0);
}

TEST_F(Program, AFailingMoveStopsTheCycleWithItsErrorAndResetClearsIt) {
    robot.unreachable = [&](const Request &r) { return r.op == OpCode::MoveL && r.target == settings.pick; };
    powerOn();
    pulse(&pou::Inputs::I0);
    ASSERT_TRUE(runUntil([&] { return out.Error; }));
    EXPECT_EQ(out.ErrorID, 3) << "the robot's ErrorID for an unreachable pose";
    EXPECT_EQ(out.Step, 0);
    EXPECT_FALSE(out.Running);
    EXPECT_EQ(robot.st.eState, 4);
    for (int i = 0; i < 10; ++i) period();
    EXPECT_TRUE(out.Error) << "latched";

    const std::size_t taken = robot.taken.size();
    pulse(&pou::Inputs::I0);
    for (int i = 0; i < 10; ++i) period();
    EXPECT_EQ(out.Step, 0) << "no Start while in error";
    EXPECT_EQ(robot.taken.size(), taken);

    pulse(&pou::Inputs::Reset);
    ASSERT_TRUE(runUntil([&] { return !out.Error; }, 20));
    EXPECT_EQ(out.ErrorID, 0);
    EXPECT_EQ(robot.lastOp(), OpCode::Reset);
    EXPECT_EQ(robot.st.eState, 1);
    EXPECT_TRUE(out.Powered);

    robot.unreachable = nullptr;
    steps.clear();
    pulse(&pou::Inputs::I0);
    ASSERT_TRUE(runUntil([&] { return !out.Running; }));
    EXPECT_EQ(steps, kOneCycle);
    EXPECT_EQ(out.Cycles, 1u);
    EXPECT_FALSE(out.Error);
}

TEST_F(Program, ADriveFaultDuringTheCycleIsReportedAndResetPowersTheRobotAgain) {
    powerOn();
    pulse(&pou::Inputs::I0);
    ASSERT_TRUE(runUntil([&] { return out.Step == 5 && robot.moving(); }));
    robot.driveFault(4);
    period();
    EXPECT_TRUE(out.Error);
    EXPECT_EQ(out.ErrorID, 4);
    EXPECT_EQ(out.Step, 0);
    EXPECT_FALSE(out.Powered);

    in.Reset = true;  // held: only the edge counts
    ASSERT_TRUE(runUntil([&] { return !out.Error && out.Powered; }, 50));
    in.Reset = false;
    EXPECT_EQ(robot.ops(robot.taken.size() - 2), (std::vector<OpCode>{OpCode::Reset, OpCode::PowerOn}));
    pulse(&pou::Inputs::I0);
    ASSERT_TRUE(runUntil([&] { return !out.Running; }));
    EXPECT_EQ(out.Cycles, 1u);
}

TEST_F(Program, DisableEndsTheCycleWithoutError) {
    powerOn();
    pulse(&pou::Inputs::I0);
    ASSERT_TRUE(runUntil([&] { return out.Step == 2 && robot.moving(); }));
    in.Enable = false;
    period();
    EXPECT_EQ(robot.svc.eOpCode, 2);
    period();
    EXPECT_EQ(out.Step, 0);
    EXPECT_FALSE(out.Error);
    ASSERT_TRUE(runUntil([&] { return !out.Powered; }));
    EXPECT_EQ(robot.st.Powered, 0);
}

TEST_F(Program, OverrideScalesEverySpeed) {
    robot.moveCycles = 1;  // 1 % of the speed makes long moves
    powerOn();
    auto firstSpeeds = [&](double override) {
        in.Override = override;
        const std::size_t from = robot.taken.size();
        pulse(&pou::Inputs::I0);
        EXPECT_TRUE(runUntil([&] { return !out.Running; }));
        const auto m = moves(from);
        return std::make_pair(m.at(0).speed, m.at(2).speed);  // a MoveJ, a MoveL
    };
    auto [j, l] = firstSpeeds(0.5);
    EXPECT_DOUBLE_EQ(j, settings.joint_speed * 0.5);
    EXPECT_DOUBLE_EQ(l, settings.linear_speed * 0.5);
    std::tie(j, l) = firstSpeeds(0.0);
    EXPECT_DOUBLE_EQ(j, settings.joint_speed * pou::kMinOverride) << "0 is clamped, never a zero speed";
    std::tie(j, l) = firstSpeeds(3.0);
    EXPECT_DOUBLE_EQ(j, settings.joint_speed);
    EXPECT_DOUBLE_EQ(l, settings.linear_speed);
}

TEST_F(Program, O0FollowsMotionDone) {
    std::vector<bool> lamp;
    auto record = [&] {
        if (lamp.empty() || lamp.back() != out.O0) lamp.push_back(out.O0);
    };
    record();
    in.Enable = true;
    for (int i = 0; i < 10; ++i) period(), record();  // period() also checks O0 == MotionDone each scan
    pulse(&pou::Inputs::I0);
    for (int i = 0; i < 5000 && out.Running; ++i) period(), record();
    ASSERT_FALSE(out.Running);
    // Off, on (power-on done), then off while moving and on at each move's end: 8 moves.
    EXPECT_EQ(lamp.size(), 2u + 2 * 8);
    EXPECT_EQ(lamp.front(), false);
    EXPECT_EQ(lamp.back(), true);
}

// ---- the program's properties -----------------------------------------------------------------

class Props {
public:
    Props(std::initializer_list<std::pair<std::string, std::string>> kv) : kv_(kv) {
        for (const auto &[k, v] : kv_) entries_.push_back({k.c_str(), v.c_str()});
        list_ = {entries_.data(), entries_.size()};
    }
    irp::Property get() const { return irp::Property(&list_); }

private:
    std::vector<std::pair<std::string, std::string>> kv_;
    std::vector<indurop_property_entry> entries_;
    indurop_property_list list_{};
};

std::string propertyError(std::initializer_list<std::pair<std::string, std::string>> kv) {
    try {
        Props p(kv);
        pou::Settings::fromProperties(p.get());
    } catch (const irp::PropertyError &e) {
        return e.what();
    }
    return "(accepted)";
}

TEST(ProgramProperties, DefaultsWhenNotSet) {
    const pou::Settings s = pou::Settings::fromProperties(Props({}).get());
    EXPECT_EQ(s.home, (Vec6{0.0, -0.5, 1.0, 0.0, 0.5, 0.0}));
    EXPECT_DOUBLE_EQ(s.joint_speed, 0.5);
    EXPECT_DOUBLE_EQ(s.linear_speed, 0.25);
    EXPECT_DOUBLE_EQ(s.lift, 0.1);
    EXPECT_EQ(s.dwell, 200ms);
    EXPECT_FALSE(s.auto_enable);
}

TEST(ProgramProperties, ReadsWaypointsAndSpeeds) {
    Props p({{"home", "0.1 0.2 0.3 0.4 0.5 0.6"},
             {"pick", " 0.5, -0.1, 0.2, 3.14, 0, -1e-1 "},
             {"place_above", "-1\t-0.5 1 0 0.5 0"},
             {"joint_speed", "0.8"},
             {"linear_speed", "1"},
             {"lift", "0.05"},
             {"dwell_ms", "0"},
             {"auto_enable", "true"}});
    const pou::Settings s = pou::Settings::fromProperties(p.get());
    EXPECT_EQ(s.home, (Vec6{0.1, 0.2, 0.3, 0.4, 0.5, 0.6}));
    EXPECT_EQ(s.pick, (Vec6{0.5, -0.1, 0.2, 3.14, 0.0, -0.1}));
    EXPECT_EQ(s.place_above, (Vec6{-1, -0.5, 1, 0, 0.5, 0}));
    EXPECT_DOUBLE_EQ(s.joint_speed, 0.8);
    EXPECT_DOUBLE_EQ(s.linear_speed, 1.0);
    EXPECT_DOUBLE_EQ(s.lift, 0.05);
    EXPECT_EQ(s.dwell, 0ms);
    EXPECT_TRUE(s.auto_enable);
}

TEST(ProgramProperties, MalformedValuesAreRefusedWithTheirName) {
    EXPECT_EQ(propertyError({{"home", "0 1 2"}}),
              "property 'home': expected 6 joint angles in rad, separated by spaces, got '0 1 2'");
    EXPECT_NE(propertyError({{"pick_above", "0 1 2 3 4 5 6"}}).find("property 'pick_above'"), std::string::npos);
    EXPECT_NE(propertyError({{"pick", "a b c d e f"}}).find("property 'pick': expected a pose"), std::string::npos);
    EXPECT_NE(propertyError({{"place", "1 2 3 4 5 nan"}}).find("property 'place'"), std::string::npos);
    EXPECT_NE(propertyError({{"place", "1 2 3 4 5 6x"}}).find("property 'place'"), std::string::npos);
    EXPECT_EQ(propertyError({{"joint_speed", "0"}}), "property 'joint_speed': expected a fraction in (0, 1], got '0'");
    EXPECT_NE(propertyError({{"accel", "1.5"}}).find("property 'accel'"), std::string::npos);
    EXPECT_NE(propertyError({{"linear_speed", "fast"}}).find("property 'linear_speed'"), std::string::npos);
    EXPECT_NE(propertyError({{"dwell_ms", "-5"}}).find("property 'dwell_ms'"), std::string::npos);
    EXPECT_NE(propertyError({{"lift", "-0.1"}}).find("property 'lift'"), std::string::npos);
}

// ---- main.so on a real segment, through the production loader ------------------------------------

// The cell's segment for this suite, made this process's segment as irpd does before loading.
class CellSegment : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        auto layout = irp::variables::readLayout(PLC_ROBOT_LAYOUT);
        ASSERT_TRUE(layout.ok()) << layout.error().message;
        auto segment = irp::variables::VariableSegment::create("test-plc-" + std::to_string(getpid()), *layout);
        ASSERT_TRUE(segment.ok()) << segment.error().message;
        segment_ = std::make_unique<irp::variables::VariableSegment>(std::move(*segment));
    }
    static void TearDownTestSuite() { segment_.reset(); }

    void SetUp() override {
        ASSERT_TRUE(segment_);
        PLC_ROBOT::I0 = 0;
        PLC_ROBOT::I1 = 0;
        PLC_ROBOT::O0 = 0;
        PLC_ROBOT::PLC_IN = PLC_ROBOT::PLC_IN_t{};
        PLC_ROBOT::PLC_OUT = PLC_ROBOT::PLC_OUT_t{};
        PLC_ROBOT::ROBOT_MODULE_SERVICE = Service{};
        PLC_ROBOT::ROBOT_MODULE_STATE = State{};
    }

    static irp::config::ModuleSpec spec(std::vector<std::pair<std::string, std::string>> props) {
        irp::config::ModuleSpec m;
        m.filename = "./main.so";
        m.path = PLC_MAIN_MODULE;
        m.name = "main";
        m.where = "sets/plc-robot/module.xml:3";
        m.line = 3;
        m.period_ns = 10'000'000;
        m.priority = 3;
        m.properties = std::move(props);
        return m;
    }

    static std::unique_ptr<irp::variables::VariableSegment> segment_;
};
std::unique_ptr<irp::variables::VariableSegment> CellSegment::segment_;

TEST_F(CellSegment, MainRefusesAMalformedWaypoint) {
    auto m = irp::hosts::ThreadModule::load(spec({{"home", "0 -0.5 1.0"}}), irp::shared::layoutHash().c_str());
    ASSERT_TRUE(m.ok()) << m.error().message;
    auto status = (*m)->initialize();
    ASSERT_FALSE(status.ok());
    EXPECT_NE(status.error().message.find("property 'home': expected 6 joint angles"), std::string::npos)
        << status.error().message;
}

TEST_F(CellSegment, MainRunsTheCycleOnTheSharedVariables) {
    auto m = irp::hosts::ThreadModule::load(spec({{"dwell_ms", "0"}, {"auto_enable", "1"}, {"joint_speed", "1"}}),
                                            irp::shared::layoutHash().c_str());
    ASSERT_TRUE(m.ok()) << m.error().message;
    ASSERT_TRUE((*m)->initialize().ok());
    ASSERT_TRUE((*m)->start().ok());
    EXPECT_EQ(PLC_ROBOT::PLC_IN.Enable.load(), 1) << "auto_enable";
    EXPECT_DOUBLE_EQ(PLC_ROBOT::PLC_IN.Override.load(), 1.0) << "a zero Override gets the property's default";
    auto runPlc = (*m)->runFunction();

    FakeRobot robot;
    std::vector<int32_t> steps;
    PLC_ROBOT::PLC_OUT_t out{};
    auto period = [&] {
        robot.svc = PLC_ROBOT::ROBOT_MODULE_SERVICE;  // Robot.so, priority 2
        robot.run();
        PLC_ROBOT::ROBOT_MODULE_STATE = robot.st;
        runPlc();  // main.so, priority 3
        out = PLC_ROBOT::PLC_OUT;
        EXPECT_EQ(PLC_ROBOT::O0.load(), robot.st.MotionDone);
        if (steps.empty() || steps.back() != out.Step) steps.push_back(out.Step);
    };
    auto runUntil = [&](auto done) {
        for (int i = 0; i < 5000 && !done(); ++i) period();
        return done();
    };
    ASSERT_TRUE(runUntil([&] { return out.Powered != 0; }));
    steps.clear();
    PLC_ROBOT::I0 = 1;
    period();
    PLC_ROBOT::I0 = 0;
    ASSERT_TRUE(runUntil([&] { return out.Running == 0; }));
    EXPECT_EQ(steps, kOneCycle);
    EXPECT_EQ(out.Done, 1);
    EXPECT_EQ(out.Cycles, 1u);
    ASSERT_EQ(robot.ops(),
              (std::vector<OpCode>{OpCode::PowerOn, OpCode::MoveJ, OpCode::MoveJ, OpCode::MoveL, OpCode::MoveL,
                                   OpCode::MoveJ, OpCode::MoveL, OpCode::MoveL, OpCode::MoveJ}));
    const pou::Settings defaults;
    for (int k = 0; k < kAxes; ++k) EXPECT_DOUBLE_EQ(robot.taken[1].target[k], defaults.home[k]);
    EXPECT_DOUBLE_EQ(robot.taken[1].speed, 1.0);
    EXPECT_EQ(PLC_ROBOT::ROBOT_MODULE_SERVICE.nSeq.load(), 9u);

    // The operator panel in the shared variables: CycleMode, then Stop.
    PLC_ROBOT::PLC_IN.CycleMode = 1;
    PLC_ROBOT::PLC_IN.Start = 1;
    period();
    PLC_ROBOT::PLC_IN.Start = 0;
    ASSERT_TRUE(runUntil([&] { return out.Cycles == 2; }));
    EXPECT_EQ(out.Running, 1);
    PLC_ROBOT::PLC_IN.Stop = 1;
    period();
    EXPECT_EQ(out.Running, 0);
    EXPECT_EQ(out.Step, 0);
    period();
    EXPECT_EQ(robot.lastOp(), OpCode::Stop);
    ASSERT_TRUE((*m)->stop().ok());
}

}  // namespace
