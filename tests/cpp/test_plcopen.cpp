// test_plcopen.cpp -- the PLC function blocks of the plc-robot cell, scan by scan against a
// simulated robot that obeys the cell's request/answer protocol (docs/plc.md): every function block
// of indurop_plcopen through its state diagram, and the IEC basics.  The pick-and-place program
// and main.so are in test_plc_program.cpp.
#include "support/fake_robot.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

using namespace plc_test;

namespace {

// ---- MC_MoveAbsolute / MC_MoveLinear -------------------------------------------------------------

TEST(MoveAbsolute, RequestsOnTheRisingEdgeIsActiveWhenTakenAndDoneWhenTheRobotFinishes) {
    Bench b;
    b.robot.powerUp();
    b.robot.moveCycles = 4;  // at Velocity 0.5: 8 runs
    MC_MoveAbsolute mv;
    mv.Position = kJointTarget;
    mv.Velocity = 0.5;
    mv.Acceleration = 0.25;

    scan(b, mv);  // Execute FALSE: nothing
    EXPECT_FALSE(mv.Busy || mv.Active || mv.Done || mv.Error || mv.CommandAborted);
    EXPECT_EQ(b.robot.svc.nSeq, 0u);

    mv.Execute = true;  // the rising edge writes the request, nSeq last
    scan(b, mv);
    EXPECT_TRUE(mv.Busy);
    EXPECT_FALSE(mv.Active) << "not taken by the robot yet";
    EXPECT_FALSE(mv.Done);
    EXPECT_EQ(b.robot.svc.nSeq, 1u);
    EXPECT_EQ(b.robot.svc.eOpCode, 3);
    EXPECT_DOUBLE_EQ(b.robot.svc.t_speed, 0.5);
    EXPECT_DOUBLE_EQ(b.robot.svc.t_accel, 0.25);
    for (int i = 0; i < kAxes; ++i) EXPECT_DOUBLE_EQ(b.robot.svc.dTarget[i], kJointTarget[i]);

    scan(b, mv);  // takes it
    EXPECT_TRUE(mv.Busy && mv.Active);
    ASSERT_EQ(b.robot.taken.size(), 1u);
    for (int run = 1; run < 8; ++run) {
        scan(b, mv);
        EXPECT_TRUE(mv.Busy && mv.Active && !mv.Done) << "run " << run;
    }
    scan(b, mv);  // the 8th run ends the move: MotionDone for nAckSeq 1
    EXPECT_TRUE(mv.Done);
    EXPECT_FALSE(mv.Busy || mv.Active || mv.Error || mv.CommandAborted);

    for (int k = 0; k < 5; ++k) {  // Done stays while Execute stays TRUE
        scan(b, mv);
        EXPECT_TRUE(mv.Done) << k;
    }
    mv.Execute = false;  // and resets with it
    scan(b, mv);
    EXPECT_FALSE(mv.Done || mv.Busy);
    EXPECT_EQ(b.robot.taken.size(), 1u) << "one request per rising edge";
}

TEST(MoveAbsolute, ExecuteFallingWhileBusyLetsTheMoveFinishAndShowsDoneForOneScan) {
    Bench b;
    b.robot.powerUp();
    MC_MoveAbsolute mv;
    mv.Position = kJointTarget;
    mv.Execute = true;
    scan(b, mv);
    mv.Execute = false;  // falls while busy
    int scans = 0;
    while (!mv.Done && scans < 100) {
        EXPECT_TRUE(mv.Busy) << "the command goes on after Execute fell";
        scan(b, mv);
        ++scans;
    }
    ASSERT_TRUE(mv.Done);
    EXPECT_FALSE(mv.Busy);
    scan(b, mv);
    EXPECT_FALSE(mv.Done) << "shown for exactly one scan";
    EXPECT_EQ(b.robot.taken.size(), 1u);
}

TEST(MoveAbsolute, RisingEdgeWhileBusyStartsANewMoveAndTheFirstGetsNoFeedback) {
    Bench b;
    b.robot.powerUp();
    MC_MoveAbsolute mv;
    mv.Position = kJointTarget;
    mv.Execute = true;
    scan(b, mv);
    scan(b, mv);
    ASSERT_TRUE(mv.Active);
    mv.Execute = false;
    scan(b, mv);
    mv.Execute = true;  // a new edge while busy
    mv.Position = Vec6{1, 1, 1, 1, 1, 1};
    scan(b, mv);
    EXPECT_EQ(b.robot.svc.nSeq, 2u);
    for (int k = 0; k < 100 && !mv.Done; ++k) {
        EXPECT_FALSE(mv.CommandAborted || mv.Error) << "the superseded command of the same instance is silent";
        EXPECT_TRUE(mv.Busy);
        scan(b, mv);
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
    scan(b, first, second);
    scan(b, first, second);
    ASSERT_TRUE(first.Active);

    second.Execute = true;  // called after `first` in the scan
    scan(b, first, second);
    EXPECT_TRUE(first.Busy && first.Active) << "the first learns of it in its next call";
    EXPECT_TRUE(second.Busy);
    EXPECT_EQ(b.robot.svc.eOpCode, 4);

    scan(b, first, second);  // takes the MoveL, replacing the MoveJ
    EXPECT_TRUE(first.CommandAborted);
    EXPECT_FALSE(first.Busy || first.Active || first.Done || first.Error);
    EXPECT_TRUE(second.Busy && second.Active);

    for (int k = 0; k < 100 && !second.Done; ++k) {
        scan(b, first, second);
        EXPECT_TRUE(first.CommandAborted) << "stays while Execute stays TRUE";
        EXPECT_FALSE(first.Done);
    }
    EXPECT_TRUE(second.Done);
    first.Execute = false;
    scan(b, first);
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
    scan(b, mv);
    EXPECT_TRUE(mv.Busy);
    scan(b, mv);  // refuses: ErrorID 3, unreachable
    EXPECT_TRUE(mv.Error);
    EXPECT_EQ(mv.ErrorID, 3);
    EXPECT_FALSE(mv.Busy || mv.Active || mv.Done || mv.CommandAborted);
    for (int k = 0; k < 3; ++k) {
        scan(b, mv);
        EXPECT_TRUE(mv.Error && mv.ErrorID == 3);
    }
    mv.Execute = false;
    scan(b, mv);
    EXPECT_FALSE(mv.Error);
    EXPECT_EQ(mv.ErrorID, 0);
}

TEST(MoveAbsolute, AMoveOnAnUnpoweredRobotFailsWithErrorID1) {
    Bench b;
    MC_MoveAbsolute mv;
    mv.Execute = true;
    scan(b, mv);
    scan(b, mv);
    EXPECT_TRUE(mv.Error);
    EXPECT_EQ(mv.ErrorID, 1);
}

TEST(MoveAbsolute, AnErrorWhileMovingComesFromTheRobotsState) {
    Bench b;
    b.robot.powerUp();
    MC_MoveAbsolute mv;
    mv.Execute = true;
    scan(b, mv);
    scan(b, mv);
    ASSERT_TRUE(mv.Active);
    b.robot.driveFault(4);
    scan(b, mv);
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
    scan(b, first);
    EXPECT_EQ(b.robot.svc.nSeq, 0xFFFFFFFFu);
    scan(b, first);
    second.Execute = true;
    second(b.g);
    EXPECT_EQ(b.robot.svc.nSeq, 0u);
    scan(b, first, second);
    EXPECT_TRUE(first.CommandAborted) << "0 comes after 0xFFFFFFFF";
    EXPECT_TRUE(second.Active);
    for (int k = 0; k < 100 && !second.Done; ++k) {
        scan(b, second);
    }
    EXPECT_TRUE(second.Done);
}

// ---- MC_Power ----------------------------------------------------------------------------------

TEST(Power, EnablePowersOnAndStatusFollowsTheRobot) {
    Bench b;
    MC_Power pw;
    scan(b, pw);
    EXPECT_FALSE(pw.Status || pw.Valid || pw.Busy || pw.Error);
    EXPECT_EQ(b.robot.svc.nSeq, 0u);

    pw.Enable = true;
    scan(b, pw);
    EXPECT_TRUE(pw.Busy);
    EXPECT_TRUE(pw.Valid);
    EXPECT_FALSE(pw.Status);
    EXPECT_EQ(b.robot.svc.eOpCode, 1);
    int scans = 0;
    while (!pw.Status && scans < 20) {
        scan(b, pw);
        ++scans;
    }
    EXPECT_TRUE(pw.Status);
    EXPECT_EQ(scans, 1 + b.robot.powerCycles) << "taken, then powerCycles runs";
    EXPECT_FALSE(pw.Busy);
    EXPECT_TRUE(pw.Valid);
    for (int k = 0; k < 5; ++k) {
        scan(b, pw);
    }
    EXPECT_EQ(b.robot.taken.size(), 1u) << "no more requests while enabled and powered";

    pw.Enable = false;
    scan(b, pw);
    EXPECT_EQ(b.robot.svc.eOpCode, 2);
    EXPECT_FALSE(pw.Valid);
    for (int k = 0; k < 20 && pw.Status; ++k) {
        scan(b, pw);
    }
    EXPECT_FALSE(pw.Status || pw.Busy || pw.Error);
    EXPECT_EQ(b.robot.ops(), (std::vector<OpCode>{OpCode::PowerOn, OpCode::PowerOff}));
}

TEST(Power, EnablingAPoweredRobotSendsNothing) {
    Bench b;
    b.robot.powerUp();
    MC_Power pw;
    pw.Enable = true;
    scan(b, pw);
    EXPECT_TRUE(pw.Status && pw.Valid);
    EXPECT_FALSE(pw.Busy);
    EXPECT_EQ(b.robot.svc.nSeq, 0u);
}

TEST(Power, APowerOnTimeoutIsAnErrorUntilEnableFalls) {
    Bench b;
    b.robot.powerOnTimesOut = true;
    MC_Power pw;
    pw.Enable = true;
    for (int k = 0; k < 20 && !pw.Error; ++k) {
        scan(b, pw);
    }
    EXPECT_TRUE(pw.Error);
    EXPECT_EQ(pw.ErrorID, 6);
    EXPECT_FALSE(pw.Valid || pw.Status || pw.Busy);
    for (int k = 0; k < 5; ++k) {
        scan(b, pw);
        EXPECT_TRUE(pw.Error);
    }
    EXPECT_EQ(b.robot.ops(), (std::vector<OpCode>{OpCode::PowerOn})) << "no retry while the group is in error";
    pw.Enable = false;
    scan(b, pw);
    EXPECT_FALSE(pw.Error);
    EXPECT_EQ(pw.ErrorID, 0);
}

TEST(Power, PowerLostIsAnErrorAndAfterResetThePowerComesBack) {
    Bench b;
    MC_Power pw;
    MC_Reset rs;
    pw.Enable = true;
    for (int k = 0; k < 20 && !pw.Status; ++k) {
        scan(b, pw, rs);
    }
    ASSERT_TRUE(pw.Status);
    b.robot.driveFault(4);
    scan(b, pw, rs);
    EXPECT_TRUE(pw.Error);
    EXPECT_EQ(pw.ErrorID, 4);
    EXPECT_FALSE(pw.Status || pw.Valid);

    rs.Execute = true;
    for (int k = 0; k < 20 && !(pw.Status && rs.Done); ++k) {
        scan(b, pw, rs);
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
    scan(b, pw, mv);
    scan(b, pw, mv);
    ASSERT_TRUE(mv.Active);
    pw.Enable = false;
    scan(b, pw, mv);
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
    scan(b, mv, st);
    scan(b, mv, st);
    ASSERT_TRUE(mv.Active);

    st.Execute = true;
    scan(b, mv, st);
    EXPECT_TRUE(st.Busy);
    EXPECT_EQ(b.robot.svc.eOpCode, 5);
    scan(b, mv, st);  // takes the stop
    EXPECT_TRUE(mv.CommandAborted);
    EXPECT_TRUE(st.Busy);
    EXPECT_EQ(b.robot.st.eState, 3) << "stopping";
    int scans = 0;
    while (!st.Done && scans < 20) {
        scan(b, mv, st);
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
    scan(b, st, other);
    EXPECT_TRUE(other.Error);
    EXPECT_EQ(other.ErrorID, error::kGroupStopping);
    EXPECT_EQ(b.robot.svc.nSeq, before);
    EXPECT_TRUE(st.Done);

    st.Execute = false;
    other.Execute = false;
    scan(b, st, other);
    EXPECT_FALSE(st.Done);
    other.Execute = true;  // released: moves again
    scan(b, st, other);
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
    scan(b, mv);
    scan(b, mv);
    st.Execute = true;
    scan(b, st);
    st.Execute = false;  // falls at once
    MC_MoveAbsolute next;
    next.Execute = true;
    scan(b, st, next);
    EXPECT_TRUE(st.Busy);
    EXPECT_TRUE(next.Error) << "still stopping";
    EXPECT_EQ(next.ErrorID, error::kGroupStopping);
    while (!st.Done && st.Busy) {
        scan(b, st);
    }
    EXPECT_TRUE(st.Done);
    scan(b, st);
    EXPECT_FALSE(st.Done) << "shown for one scan";
    next.Execute = false;
    next(b.g);
    next.Execute = true;
    next(b.g);
    EXPECT_TRUE(next.Busy && !next.Error) << "the group is free again";
}

// The Structured Text runtime keeps every block instance in shared memory and copies it in and
// out around each scan, so an instance is at another address in every call: a block must not
// be known to the group by its address.
TEST(Stop, AnInstanceCopiedInAndOutEveryScanStillReleasesTheGroup) {
    Bench b;
    b.robot.powerUp();
    MC_Stop stored;                  // the copy in shared memory
    std::array<MC_Stop, 16> images;  // the run's local copy: another place in each scan
    std::size_t scans = 0;
    auto scanCopied = [&] {
        MC_Stop &local = images.at(scans++);
        local = stored;
        scan(b, local);
        stored = local;
    };
    stored.Execute = true;
    ASSERT_TRUE(runUntil([&] { return stored.Done; }, scanCopied, 10));
    stored.Execute = false;
    scanCopied();
    MC_MoveAbsolute mv;
    mv.Execute = true;
    mv(b.g);
    EXPECT_TRUE(mv.Busy) << "the group is free again";
    EXPECT_FALSE(mv.Error) << "ErrorID " << mv.ErrorID;
}

// ---- MC_Reset ----------------------------------------------------------------------------------

TEST(Reset, ClearsTheGroupsError) {
    Bench b;
    b.robot.powerUp();
    b.robot.unreachable = [](const Request &) { return true; };
    MC_MoveAbsolute mv;
    MC_Reset rs;
    mv.Execute = true;
    scan(b, mv);
    scan(b, mv);
    ASSERT_TRUE(mv.Error);
    ASSERT_EQ(b.robot.st.eState, 4);

    rs.Execute = true;
    scan(b, rs);
    EXPECT_TRUE(rs.Busy);
    EXPECT_EQ(b.robot.svc.eOpCode, 6);
    scan(b, rs);
    EXPECT_TRUE(rs.Done);
    EXPECT_FALSE(rs.Busy || rs.Error);
    EXPECT_EQ(b.robot.st.Error, 0);
    EXPECT_EQ(b.robot.st.eState, 1);
    rs.Execute = false;
    scan(b, rs);
    EXPECT_FALSE(rs.Done);
}

TEST(Reset, WithoutAnErrorItIsDoneAtOnceAndSendsNothing) {
    Bench b;
    b.robot.powerUp();
    MC_MoveAbsolute mv;
    MC_Reset rs;
    mv.Execute = true;
    scan(b, mv, rs);
    rs.Execute = true;
    scan(b, mv, rs);
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
    scan(b, rs);
    for (int k = 0; k < 3; ++k) {
        scan(b, rs);
        EXPECT_TRUE(rs.Busy) << k;
        EXPECT_FALSE(rs.Error) << k;
    }
    scan(b, rs);
    EXPECT_TRUE(rs.Done);
    EXPECT_EQ(b.robot.st.eState, 0) << "unpowered: disabled after the reset";
}

TEST(Reset, ARefusedResetIsAnError) {
    Bench b;
    b.robot.driveFault(4);
    b.robot.resetFails = true;
    MC_Reset rs;
    rs.Execute = true;
    scan(b, rs);
    scan(b, rs);
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

}  // namespace
