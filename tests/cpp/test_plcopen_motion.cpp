// test_plcopen_motion.cpp -- the PLCopen blocks added for Structured Text (MC_Home,
// MC_MoveRelative, MC_MoveVelocity, MC_ReadActualPosition, MC_ReadStatus, MC_ReadAxisError), scan
// by scan against the simulated robot of the plc-robot protocol (support/fake_robot.hpp), as
// test_plcopen.cpp does for the others: every output per call through a whole command, aborts by
// a later command, refusals with their ErrorID; and every block used as the ST runtime uses it,
// copied in and out of its shared variable around each call.
#include "support/fake_robot.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

using namespace plc_test;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---- MC_Home -----------------------------------------------------------------------------------

TEST(Home, MovesToThePositionAndTheGroupIsHomedUntilItLosesPower) {
    Bench b;
    b.robot.powerUp();
    MC_Home home;
    MC_ReadStatus status;
    status.Enable = true;
    home.Velocity = 0.5;
    scan(b, home, status);
    EXPECT_FALSE(home.Busy || home.Done || status.IsHomed || status.Homing);
    EXPECT_TRUE(status.Standstill);

    home.Execute = true;  // the edge writes a MoveJ to the home position: every joint 0 by default
    scan(b, home, status);
    EXPECT_TRUE(home.Busy);
    EXPECT_FALSE(home.Active);
    EXPECT_EQ(b.robot.svc.eOpCode, 3);
    EXPECT_DOUBLE_EQ(b.robot.svc.t_speed, 0.5);
    for (int i = 0; i < kAxes; ++i) EXPECT_EQ(b.robot.svc.dTarget[i], 0.0);
    EXPECT_TRUE(status.Homing) << "the home request runs";

    scan(b, home, status);  // taken
    EXPECT_TRUE(home.Busy && home.Active);
    EXPECT_TRUE(status.Homing);
    EXPECT_FALSE(status.DiscreteMotion);
    int scans = 0;
    while (!home.Done && scans++ < 50) {
        EXPECT_TRUE(home.Busy);
        scan(b, home, status);
    }
    ASSERT_TRUE(home.Done);
    EXPECT_FALSE(home.Busy || home.Active || home.Error || home.CommandAborted);
    EXPECT_TRUE(status.IsHomed);
    EXPECT_FALSE(status.Homing);
    EXPECT_TRUE(status.Standstill);

    scan(b, home, status);
    EXPECT_TRUE(home.Done) << "held while Execute";
    home.Execute = false;
    scan(b, home, status);
    EXPECT_FALSE(home.Done);
    EXPECT_TRUE(status.IsHomed) << "homed stays after the command";

    b.robot.driveFault(4);  // power lost
    scan(b, home, status);
    EXPECT_FALSE(status.IsHomed);
    EXPECT_TRUE(status.ErrorStop);
    EXPECT_EQ(b.robot.taken.size(), 1u);
}

TEST(Home, ANewerMoveAbortsItAndTheGroupIsNotHomed) {
    Bench b;
    b.robot.powerUp();
    MC_Home home;
    MC_MoveAbsolute move;
    MC_ReadStatus status;
    status.Enable = home.Execute = true;
    scan(b, home, move, status);
    scan(b, home, move, status);
    ASSERT_TRUE(home.Active);
    move.Execute = true;
    move.Position = kJointTarget;
    scan(b, home, move, status);
    scan(b, home, move, status);  // the robot took the move
    EXPECT_TRUE(home.CommandAborted);
    EXPECT_FALSE(home.Busy || home.Active || home.Done);
    EXPECT_FALSE(status.IsHomed || status.Homing);
    EXPECT_TRUE(status.DiscreteMotion);
}

TEST(Home, BadParametersAndAStoppingGroupAreRefusedWithoutARequest) {
    Bench b;
    b.robot.powerUp();
    MC_Home home;
    home.Position[2] = kNaN;
    home.Execute = true;
    scan(b, home);
    EXPECT_TRUE(home.Error);
    EXPECT_EQ(home.ErrorID, error::kInvalidParameter);
    EXPECT_FALSE(home.Busy);

    MC_Stop stop;
    stop.Execute = true;
    MC_Home second;
    second.Execute = true;
    const uint32_t before = b.robot.svc.nSeq;
    stop(b.g);
    second(b.g);
    EXPECT_TRUE(second.Error);
    EXPECT_EQ(second.ErrorID, error::kGroupStopping);
    EXPECT_EQ(b.robot.svc.nSeq, before + 1) << "only the stop was written";
}

// ---- MC_MoveRelative ---------------------------------------------------------------------------

TEST(MoveRelative, MovesByDistanceFromTheCommandedJointsAtTheEdge) {
    Bench b;
    b.robot.powerUp();
    const Vec6 start{0.1, 0.2, 0.3, 0.4, 0.5, 0.6};
    for (int i = 0; i < kAxes; ++i) b.robot.st.dCmdJoint[i] = start[i];
    MC_MoveRelative rel;
    rel.Distance = {0.5, -0.5, 0, 0, 0, 1};
    rel.Velocity = 0.25;
    rel.Acceleration = 0.5;
    scan(b, rel);
    EXPECT_FALSE(rel.Busy || rel.Done);

    rel.Execute = true;
    scan(b, rel);
    EXPECT_TRUE(rel.Busy);
    EXPECT_FALSE(rel.Active);
    EXPECT_EQ(b.robot.svc.eOpCode, 3) << "a joint PTP";
    for (int i = 0; i < kAxes; ++i) EXPECT_DOUBLE_EQ(b.robot.svc.dTarget[i], start[i] + rel.Distance[i]);
    EXPECT_DOUBLE_EQ(b.robot.svc.t_speed, 0.25);
    EXPECT_DOUBLE_EQ(b.robot.svc.t_accel, 0.5);

    scan(b, rel);
    EXPECT_TRUE(rel.Busy && rel.Active);
    int scans = 0;
    while (!rel.Done && scans++ < 100) {
        EXPECT_TRUE(rel.Busy && rel.Active);
        scan(b, rel);
    }
    ASSERT_TRUE(rel.Done);
    EXPECT_FALSE(rel.Busy || rel.Active || rel.Error || rel.CommandAborted);
    EXPECT_DOUBLE_EQ(b.robot.st.dCmdJoint[5], 1.6);
    scan(b, rel);
    EXPECT_TRUE(rel.Done);
    rel.Execute = false;
    scan(b, rel);
    EXPECT_FALSE(rel.Done);

    rel.Execute = true;  // a second edge moves on from where the first ended
    scan(b, rel);
    EXPECT_DOUBLE_EQ(b.robot.svc.dTarget[0], start[0] + 2 * 0.5);
    EXPECT_DOUBLE_EQ(b.robot.svc.dTarget[5], start[5] + 2 * 1.0);
}

TEST(MoveRelative, AStopAbortsIt) {
    Bench b;
    b.robot.powerUp();
    MC_MoveRelative rel;
    MC_Stop stop;
    rel.Distance[0] = 1;
    rel.Execute = true;
    scan(b, rel, stop);
    scan(b, rel, stop);
    ASSERT_TRUE(rel.Active);
    stop.Execute = true;
    scan(b, rel, stop);
    scan(b, rel, stop);
    EXPECT_TRUE(rel.CommandAborted);
    EXPECT_FALSE(rel.Busy || rel.Active || rel.Done || rel.Error);
}

TEST(MoveRelative, BadInputsAndAnUnboundGroupAreErrors) {
    Bench b;
    b.robot.powerUp();
    auto attempt = [&](auto setup, AxisGroupRef &g) {
        MC_MoveRelative rel;
        setup(rel);
        rel.Execute = true;
        const uint32_t before = b.robot.svc.nSeq;
        rel(g);
        EXPECT_EQ(b.robot.svc.nSeq, before) << "no request written";
        EXPECT_FALSE(rel.Busy);
        return rel.Error ? rel.ErrorID : 0;
    };
    EXPECT_EQ(attempt([](MC_MoveRelative &r) { r.Distance[1] = kNaN; }, b.g), error::kInvalidParameter);
    EXPECT_EQ(attempt([](MC_MoveRelative &r) { r.Velocity = 0; }, b.g), error::kInvalidParameter);
    EXPECT_EQ(attempt([](MC_MoveRelative &r) { r.Acceleration = 2; }, b.g), error::kInvalidParameter);
    AxisGroupRef unbound;
    EXPECT_EQ(attempt([](MC_MoveRelative &) {}, unbound), error::kNotBound);
}

// ---- MC_MoveVelocity ---------------------------------------------------------------------------

TEST(MoveVelocity, RunsAtTheVelocityUntilAStopAbortsIt) {
    Bench b;
    b.robot.powerUp();
    b.robot.rampCycles = 3;
    MC_MoveVelocity jog;
    MC_Stop stop;
    MC_ReadStatus status;
    status.Enable = true;
    jog.Velocity = {0.5, 0, 0, 0, 0, -0.25};
    jog.Acceleration = 0.4;
    scan(b, jog, stop, status);
    EXPECT_FALSE(jog.Busy || jog.InVelocity);

    jog.Execute = true;
    scan(b, jog, stop, status);
    EXPECT_TRUE(jog.Busy);
    EXPECT_FALSE(jog.Active || jog.InVelocity);
    EXPECT_EQ(b.robot.svc.eOpCode, 7);
    EXPECT_DOUBLE_EQ(b.robot.svc.t_accel, 0.4);
    for (int i = 0; i < kAxes; ++i) EXPECT_DOUBLE_EQ(b.robot.svc.dTarget[i], jog.Velocity[i]);

    for (int k = 0; k < 3; ++k) {  // taken, accelerating
        scan(b, jog, stop, status);
        EXPECT_TRUE(jog.Busy && jog.Active) << k;
        EXPECT_FALSE(jog.InVelocity) << k;
        EXPECT_TRUE(status.ContinuousMotion);
    }
    scan(b, jog, stop, status);
    EXPECT_TRUE(jog.InVelocity);
    EXPECT_TRUE(jog.Busy && jog.Active) << "the command goes on at its velocity";
    EXPECT_FALSE(jog.Error || jog.CommandAborted);

    jog.Execute = false;  // a falling Execute does not end a motion
    for (int k = 0; k < 5; ++k) {
        scan(b, jog, stop, status);
        EXPECT_TRUE(jog.Busy && jog.Active && jog.InVelocity) << k;
    }

    stop.Execute = true;  // an MC_Stop takes over
    scan(b, jog, stop, status);
    EXPECT_TRUE(jog.InVelocity) << "learns of it in its next call";
    scan(b, jog, stop, status);
    EXPECT_TRUE(jog.CommandAborted) << "shown once: Execute fell while busy";
    EXPECT_FALSE(jog.Busy || jog.Active || jog.InVelocity || jog.Error);
    EXPECT_TRUE(status.Stopping);
    scan(b, jog, stop, status);
    EXPECT_FALSE(jog.CommandAborted);
    EXPECT_EQ(b.robot.ops(), (std::vector<OpCode>{OpCode::MoveVelocity, OpCode::Stop}));
}

TEST(MoveVelocity, ANewerMoveAbortsItAndAnOutcomeStaysWhileExecute) {
    Bench b;
    b.robot.powerUp();
    MC_MoveVelocity jog;
    MC_MoveAbsolute move;
    jog.Velocity[3] = -1;
    jog.Execute = true;
    for (int k = 0; k < 6; ++k) scan(b, jog, move);
    ASSERT_TRUE(jog.InVelocity);
    move.Execute = true;
    scan(b, jog, move);
    scan(b, jog, move);
    EXPECT_TRUE(jog.CommandAborted);
    EXPECT_FALSE(jog.Busy || jog.InVelocity);
    EXPECT_TRUE(move.Active);
    for (int k = 0; k < 3; ++k) {
        scan(b, jog, move);
        EXPECT_TRUE(jog.CommandAborted) << "while Execute stays TRUE";
    }
}

TEST(MoveVelocity, AJointAtItsLimitIsAnErrorWithTheRobotsErrorID) {
    Bench b;
    b.robot.powerUp();
    b.robot.rampCycles = 2;
    b.robot.limitCycles = 4;
    MC_MoveVelocity jog;
    MC_ReadAxisError axisError;
    axisError.Enable = true;
    jog.Velocity[0] = 1;
    jog.Execute = true;
    ASSERT_TRUE(runUntil([&] { return jog.Error; }, [&] { scan(b, jog, axisError); }, 20));
    EXPECT_EQ(jog.ErrorID, 2);
    EXPECT_FALSE(jog.Busy || jog.Active || jog.InVelocity || jog.CommandAborted);
    EXPECT_EQ(axisError.AxisErrorID, 2);
    jog.Execute = false;
    scan(b, jog, axisError);
    EXPECT_FALSE(jog.Error);
    EXPECT_EQ(jog.ErrorID, 0);
}

TEST(MoveVelocity, AMotionTheRobotDropsEndsWithError1005) {
    Bench b;
    b.robot.powerUp();
    MC_MoveVelocity jog;
    jog.Velocity[1] = 0.1;
    jog.Execute = true;
    for (int k = 0; k < 6; ++k) scan(b, jog);
    ASSERT_TRUE(jog.InVelocity);
    b.robot.dropMotion();  // Robot.so reloaded: the robot stands, nobody asked it to
    scan(b, jog);
    EXPECT_TRUE(jog.Error);
    EXPECT_EQ(jog.ErrorID, error::kMotionEnded);
    EXPECT_FALSE(jog.Busy || jog.InVelocity);
}

TEST(MoveVelocity, BadInputsAreRefusedWithoutARequest) {
    Bench b;
    b.robot.powerUp();
    auto attempt = [&](auto setup, AxisGroupRef &g) {
        MC_MoveVelocity jog;
        jog.Velocity[0] = 0.5;
        setup(jog);
        jog.Execute = true;
        const uint32_t before = b.robot.svc.nSeq;
        jog(g);
        EXPECT_EQ(b.robot.svc.nSeq, before) << "no request written";
        EXPECT_FALSE(jog.Busy);
        return jog.Error ? jog.ErrorID : 0;
    };
    EXPECT_EQ(attempt([](MC_MoveVelocity &j) { j.Velocity[0] = 0; }, b.g), error::kInvalidParameter) << "all 0";
    EXPECT_EQ(attempt([](MC_MoveVelocity &j) { j.Velocity[4] = -1.5; }, b.g), error::kInvalidParameter);
    EXPECT_EQ(attempt([](MC_MoveVelocity &j) { j.Velocity[2] = kNaN; }, b.g), error::kInvalidParameter);
    EXPECT_EQ(attempt([](MC_MoveVelocity &j) { j.Acceleration = 0; }, b.g), error::kInvalidParameter);
    AxisGroupRef unbound;
    EXPECT_EQ(attempt([](MC_MoveVelocity &) {}, unbound), error::kNotBound);
    b.g.status->Stopping = true;
    EXPECT_EQ(attempt([](MC_MoveVelocity &) {}, b.g), error::kGroupStopping);
}

TEST(MoveVelocity, OnAnUnpoweredRobotTheRobotRefusesIt) {
    Bench b;
    MC_MoveVelocity jog;
    jog.Velocity[0] = 0.5;
    jog.Execute = true;
    scan(b, jog);
    scan(b, jog);
    EXPECT_TRUE(jog.Error);
    EXPECT_EQ(jog.ErrorID, 1);
}

// ---- the Read blocks ---------------------------------------------------------------------------

TEST(ReadActualPosition, ReadsTheMeasuredJointsWhileEnabled) {
    Bench b;
    const Vec6 q{0.5, -0.4, 0.3, -0.2, 0.1, 0};
    for (int i = 0; i < kAxes; ++i) b.robot.st.dCurJoint[i] = q[i], b.robot.st.dCmdJoint[i] = 9;
    MC_ReadActualPosition pos;
    pos(b.g);
    EXPECT_FALSE(pos.Valid || pos.Busy || pos.Error);
    EXPECT_EQ(pos.Position, Vec6{});
    pos.Enable = true;
    pos(b.g);
    EXPECT_TRUE(pos.Valid);
    EXPECT_FALSE(pos.Busy || pos.Error);
    EXPECT_EQ(pos.Position, q) << "the drives' positions, not the command";
    b.robot.st.dCurJoint[0] = 1.0;
    pos(b.g);
    EXPECT_EQ(pos.Position[0], 1.0) << "read in every call";
    pos.Enable = false;
    pos(b.g);
    EXPECT_FALSE(pos.Valid);
    EXPECT_EQ(pos.Position, Vec6{});
    AxisGroupRef unbound;
    pos.Enable = true;
    pos(unbound);
    EXPECT_TRUE(pos.Error);
    EXPECT_EQ(pos.ErrorID, error::kNotBound);
    EXPECT_FALSE(pos.Valid);
}

TEST(ReadStatus, FollowsTheGroupThroughItsStates) {
    Bench b;
    MC_Power power;
    MC_MoveAbsolute move;
    MC_Stop stop;
    MC_Reset reset;
    MC_ReadStatus st;
    auto one = [&](const MC_ReadStatus &s) {
        return s.ErrorStop + s.Disabled + s.Stopping + s.Homing + s.Standstill + s.DiscreteMotion + s.ContinuousMotion +
               s.SynchronizedMotion;
    };
    auto step = [&] { scan(b, power, move, stop, reset, st); };
    step();
    EXPECT_FALSE(st.Valid);
    EXPECT_EQ(one(st), 0) << "nothing while not enabled";
    st.Enable = true;
    step();
    EXPECT_TRUE(st.Valid && st.Disabled);
    power.Enable = true;
    runUntil([&] { return power.Status; }, step, 10);
    EXPECT_TRUE(st.Standstill);
    move.Execute = true;
    step();
    step();
    EXPECT_TRUE(st.DiscreteMotion);
    stop.Execute = true;
    step();
    step();
    EXPECT_TRUE(st.Stopping);
    for (int k = 0; k < 10; ++k) step();
    EXPECT_TRUE(st.Stopping) << "held by the MC_Stop while its Execute is TRUE";
    EXPECT_EQ(b.robot.st.eState, 1);
    stop.Execute = false;
    step();
    EXPECT_TRUE(st.Standstill);
    b.robot.driveFault(5);
    step();
    EXPECT_TRUE(st.ErrorStop);
    EXPECT_FALSE(st.Error) << "the block itself is fine";
    for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(one(st), 1) << "one state at a time";
        step();
    }
    AxisGroupRef unbound;
    st(unbound);
    EXPECT_TRUE(st.Error);
    EXPECT_EQ(st.ErrorID, error::kNotBound);
    EXPECT_EQ(one(st), 0);
}

TEST(ReadAxisError, ShowsTheRobotsErrorWhileEnabled) {
    Bench b;
    MC_ReadAxisError re;
    re(b.g);
    EXPECT_FALSE(re.Valid);
    re.Enable = true;
    re(b.g);
    EXPECT_TRUE(re.Valid);
    EXPECT_FALSE(re.Busy || re.Error);
    EXPECT_EQ(re.AxisErrorID, 0);
    b.robot.driveFault(8);
    re(b.g);
    EXPECT_EQ(re.AxisErrorID, 8);
    re.Enable = false;
    re(b.g);
    EXPECT_EQ(re.AxisErrorID, 0);
    EXPECT_FALSE(re.Valid);
    AxisGroupRef unbound;
    re.Enable = true;
    re(unbound);
    EXPECT_TRUE(re.Error);
    EXPECT_EQ(re.ErrorID, error::kNotBound);
}

// ---- as the Structured Text runtime holds them -------------------------------------------------

// Each block instance lives in a shared variable: every scan copies it into the run's image (at
// another address each time), calls it there, and copies it back; so does the group's status.
TEST(SharedVariables, BlocksCopiedInAndOutEveryScanRunTheCellsCommands) {
    FakeRobot robot;
    robot.powerUp();
    struct Shared {  // what the shared memory holds
        MC_Home home;
        MC_MoveRelative rel;
        MC_MoveVelocity jog;
        MC_Stop stop;
        MC_ReadStatus status;
        GroupStatus group;
    } shared{};
    std::vector<Shared> images(200);  // a fresh place for each scan's copy
    std::size_t scans = 0;
    auto scan = [&](auto rung) {
        Shared &img = images.at(scans++);
        img = shared;
        AxisGroupRef g = bindAxisGroup(robot.svc, robot.st, img.group);  // built in every run
        robot.run();
        rung(img);
        img.home(g);
        img.rel(g);
        img.jog(g);
        img.stop(g);
        img.status(g);
        shared = img;
    };
    auto until = [&](auto rung, auto done) {
        for (int k = 0; k < 40; ++k) {
            scan(rung);
            if (done(shared)) return true;
        }
        return false;
    };
    shared.status.Enable = true;
    ASSERT_TRUE(until([](Shared &s) { s.home.Execute = true; }, [](const Shared &s) { return s.home.Done; }));
    EXPECT_TRUE(shared.status.IsHomed);
    ASSERT_TRUE(until(
        [](Shared &s) {
            s.home.Execute = false;
            s.rel.Execute = true;
            s.rel.Distance[0] = 0.5;
        },
        [](const Shared &s) { return s.rel.Done; }));
    EXPECT_DOUBLE_EQ(robot.st.dCmdJoint[0], 0.5);
    ASSERT_TRUE(until(
        [](Shared &s) {
            s.jog.Execute = true;
            s.jog.Velocity[0] = 0.2;
        },
        [](const Shared &s) { return s.jog.InVelocity; }));
    EXPECT_TRUE(shared.status.ContinuousMotion);
    ASSERT_TRUE(until([](Shared &s) { s.stop.Execute = true; }, [](const Shared &s) { return s.stop.Done; }));
    EXPECT_TRUE(shared.jog.CommandAborted);
    EXPECT_TRUE(shared.status.Stopping);
    ASSERT_TRUE(until([](Shared &s) { s.stop.Execute = false; }, [](const Shared &s) { return s.status.Standstill; }));
    EXPECT_FALSE(shared.group.Stopping) << "released by the copy of the MC_Stop that took it";
    EXPECT_EQ(robot.ops(), (std::vector<OpCode>{OpCode::MoveJ, OpCode::MoveJ, OpCode::MoveVelocity, OpCode::Stop}));
}

}  // namespace
