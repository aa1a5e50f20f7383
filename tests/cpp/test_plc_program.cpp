// test_plc_program.cpp -- the pick-and-place POU of config/sets/plc-robot/POUS.h through its whole
// cycle against the simulated robot (support/fake_robot.hpp), its properties, and main.so itself
// through the production loader on a real shared-variable segment of cell.glb.
#include "POUS.h"

#include "hosts/thread_module.hpp"
#include "support/fake_robot.hpp"
#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"

#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <string>
#include <unistd.h>
#include <vector>

using namespace plc_test;

namespace {

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
        return plc_test::runUntil(
            done, [this] { period(); }, max);
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
    GroupStatus status;
    AxisGroupRef g = bindAxisGroup(robot.svc, robot.st, status);
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

TEST_F(Program, DisableWhileTheRobotMovesAbortsTheCycleWithThePowerRemovedFault) {
    powerOn();
    pulse(&pou::Inputs::I0);
    ASSERT_TRUE(runUntil([&] { return out.Step == 2 && robot.moving(); }));
    const std::size_t before = robot.taken.size();
    in.Enable = false;
    period();
    EXPECT_EQ(robot.svc.eOpCode, 2);
    EXPECT_EQ(out.Step, 0);
    EXPECT_TRUE(out.Error);
    EXPECT_EQ(out.ErrorID, pou::kPowerRemoved) << "not the robot's 1 (a motion before power-on)";
    ASSERT_TRUE(runUntil([&] { return !out.Powered; }));
    EXPECT_EQ(robot.st.Powered, 0);
    EXPECT_EQ(robot.ops(before), (std::vector<OpCode>{OpCode::PowerOff})) << "no move after the power-off";
    pulse(&pou::Inputs::Reset);
    EXPECT_FALSE(out.Error);
}

TEST_F(Program, DisableInADwellRequestsNoMoveAfterThePowerOff) {
    settings.dwell = 200ms;
    program = std::make_unique<pou::PickAndPlace>(settings);
    powerOn();
    pulse(&pou::Inputs::I0);
    ASSERT_TRUE(runUntil([&] {  // MoveL_PickDown taken and done: the dwell
        return out.Step == 3 && robot.lastOp() == OpCode::MoveL && robot.st.MotionDone == 1;
    }));
    const std::size_t before = robot.taken.size();
    in.Enable = false;  // the robot stands at the pick pose; the dwell would then ask for the next move
    for (int i = 0; i < 50; ++i) period();
    EXPECT_EQ(robot.ops(before), (std::vector<OpCode>{OpCode::PowerOff}));
    EXPECT_EQ(out.ErrorID, pou::kPowerRemoved);
    EXPECT_EQ(robot.st.Error, 0);
}

TEST_F(Program, StopThenDisableWhenIdleIsACleanStop) {
    in.CycleMode = 1;
    powerOn();
    pulse(&pou::Inputs::I0);
    ASSERT_TRUE(runUntil([&] { return out.Step == 5 && robot.moving(); }));
    in.Stop = true;
    ASSERT_TRUE(runUntil([&] { return !out.Running && robot.st.Busy == 0; }));
    in.Enable = false;
    ASSERT_TRUE(runUntil([&] { return !out.Powered; }));
    in.Stop = false;
    for (int i = 0; i < 20; ++i) period();
    EXPECT_FALSE(out.Error);
    EXPECT_EQ(out.ErrorID, 0);
    EXPECT_EQ(robot.st.Error, 0);
    EXPECT_EQ(robot.lastOp(), OpCode::PowerOff);
}

TEST_F(Program, EnableWaitsForTheDrivesAndPowersOnWhenTheyAnswer) {
    in.DrivesReachable = false;  // after a (re)start: the fieldbus is not up yet
    in.Enable = true;
    for (int i = 0; i < 20; ++i) period();
    EXPECT_TRUE(robot.taken.empty()) << "no power-on request the robot would refuse with ErrorID 8";
    EXPECT_TRUE(out.WaitingForDrives);
    EXPECT_FALSE(out.Error);
    EXPECT_FALSE(out.Powered);
    in.DrivesReachable = true;
    ASSERT_TRUE(runUntil([&] { return out.Powered; }));
    EXPECT_FALSE(out.WaitingForDrives);
    EXPECT_EQ(robot.ops(), (std::vector<OpCode>{OpCode::PowerOn}));
    in.Enable = false;
    period();
    EXPECT_FALSE(out.WaitingForDrives);
}

TEST_F(Program, ACommLossOncePoweredStillFaults) {
    powerOn();
    in.DrivesReachable = false;
    robot.driveFault(8);
    period();
    EXPECT_TRUE(out.Error);
    EXPECT_EQ(out.ErrorID, 8);
    EXPECT_FALSE(out.WaitingForDrives) << "the power-on stands: a loss once powered is a fault";
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
    auto runUntil = [&](const std::function<bool()> &done) { return plc_test::runUntil(done, period, 5000); };
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
