// test_robot_module.cpp -- Robot.so (config/sets/plc-robot) loaded through irpd's own loader into
// a real shared-variable segment of the cell's layout, and run period by period as irpd would:
// first a fake drive loop standing in for the I/O dispatcher and the drives (a CiA 402 state
// machine per axis that follows AXIS_OUT into AXIS_IN), then Robot's run(), then the "PLC" side
// (requests written into ROBOT_MODULE_SERVICE as the contract says).  Covers the request/answer
// protocol, power sequencing, motions, replacement, stop, every ErrorID and reset, the properties,
// and that run() allocates nothing.  The end-to-end cell (real I/O, drive simulator) is tested
// through irpd elsewhere.
#include "hosts/thread_module.hpp"
#include "support/allocation_counter.hpp"
#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"

#include <indurop/generated.h>
#include <indurop/indurop.h>
#include <indurop/kinematics/robot.hpp>

#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

using namespace PLC_ROBOT;
using irp::kin::Joints;
using testing_support::AllocationCounter;

namespace {

using AxesIn = INDUROP_TYPEDEF(AXIS_IN)::array_type;
using AxesOut = INDUROP_TYPEDEF(AXIS_OUT)::array_type;

const std::string kSet = std::string(BUILD_ROOT) + "/sets/plc-robot";
const double kDt = 0.01;  // Robot's run() outside irpd's dispatcher assumes 10 ms periods

class Segment : public ::testing::Environment {
public:
    void SetUp() override {
        auto layout = irp::variables::readLayout(kSet + "/layout.json");
        ASSERT_TRUE(layout.ok()) << layout.error().message;
        auto segment = irp::variables::VariableSegment::create("test-robot-" + std::to_string(getpid()), *layout);
        ASSERT_TRUE(segment.ok()) << segment.error().message;
        segment_ = std::make_unique<irp::variables::VariableSegment>(std::move(*segment));
    }
    void TearDown() override { segment_.reset(); }
    static std::unique_ptr<irp::variables::VariableSegment> segment_;
};
std::unique_ptr<irp::variables::VariableSegment> Segment::segment_;
const auto *const kEnvironment = ::testing::AddGlobalTestEnvironment(new Segment);

// ---- the fake drives: CiA 402 as the contract states it -------------------------------------------
enum class DS { NotReady, SwitchOnDisabled, Ready, SwitchedOn, Enabled, QuickStop, Fault };

uint16_t statusword(DS s) {
    switch (s) {
    case DS::NotReady: return 0x00;
    case DS::SwitchOnDisabled: return 0x40;
    case DS::Ready: return 0x21;
    case DS::SwitchedOn: return 0x23;
    case DS::Enabled: return 0x27;
    case DS::QuickStop: return 0x07;
    case DS::Fault: return 0x08;
    }
    return 0;
}

struct FakeDrives {
    std::array<DS, 6> state{};
    std::array<double, 6> position{};
    std::array<uint16_t, 6> last_cw{};
    std::array<bool, 6> frozen{};                       // follows no command (a following error)
    std::array<bool, 6> deaf{};                         // ignores controlwords (a power-on timeout)
    std::vector<std::array<uint16_t, 6>> controlwords;  // every period's, as sent
    bool comm_lost = false;

    void step() {
        AxesOut out = AXIS_OUT;
        std::array<uint16_t, 6> cws{};
        for (int i = 0; i < 6; ++i) {
            uint16_t cw = out[i].controlword;
            cws[i] = cw;
            DS &s = state[i];
            bool edge = (cw & 0x80) && !(last_cw[i] & 0x80);
            last_cw[i] = cw;
            if (comm_lost || deaf[i]) continue;
            if (s == DS::Fault) {
                if (edge) s = DS::SwitchOnDisabled;
            } else if (s == DS::NotReady) {
                s = DS::SwitchOnDisabled;
            } else if (s == DS::QuickStop) {
                s = DS::SwitchOnDisabled;   // quick stop done: to switch on disabled
            } else if ((cw & 0x02) == 0) {  // disable voltage
                s = DS::SwitchOnDisabled;
            } else if ((cw & 0x04) == 0) {  // quick stop
                s = s == DS::Enabled ? DS::QuickStop : DS::SwitchOnDisabled;
            } else if ((cw & 0x0F) == 0x06) {  // shutdown
                s = DS::Ready;
            } else if ((cw & 0x0F) == 0x07) {  // switch on
                if (s == DS::Ready || s == DS::Enabled) s = DS::SwitchedOn;
            } else if ((cw & 0x0F) == 0x0F) {  // enable operation
                if (s == DS::SwitchedOn || s == DS::Enabled) s = DS::Enabled;
            }
            if (s == DS::Enabled && !frozen[i]) position[i] = out[i].position;
        }
        controlwords.push_back(cws);
        if (comm_lost) {  // the I/O dispatcher keeps the last inputs and raises the flag
            IO_STATUS.comm_lost[0] = 1;
            return;
        }
        AxesIn in{};
        for (int i = 0; i < 6; ++i) {
            in[i].statusword = statusword(state[i]);
            in[i].mode = 8;
            in[i].position = position[i];
        }
        AXIS_IN = in;
        IO_STATUS.comm_lost[0] = 0;
    }
};

using Properties = std::vector<std::pair<std::string, std::string>>;

std::unique_ptr<irp::hosts::ThreadModule> loadRobot(const Properties &props, std::string *error = nullptr) {
    irp::config::ModuleSpec spec;
    spec.name = "Robot";
    spec.filename = "./Robot.so";
    spec.path = kSet + "/Robot.so";
    spec.where = kSet + "/module.xml:1";
    spec.set_dir = kSet;  // as the parser sets it: the folder of module.xml
    spec.period_ns = 10'000'000;
    spec.priority = 2;
    spec.properties = props;
    auto m = irp::hosts::ThreadModule::load(spec, INDUROP_LAYOUT_HASH);
    if (!m) {
        if (error) *error = m.error().message;
        return nullptr;
    }
    if (auto s = (*m)->initialize(); !s) {
        if (error) *error = s.error().message;
        return nullptr;
    }
    if (auto s = (*m)->start(); !s) {
        if (error) *error = s.error().message;
        return nullptr;
    }
    return std::move(*m);
}

class RobotModule : public ::testing::Test {
protected:
    void SetUp() override {
        states.clear();
        states.reserve(100000);  // no allocation while run() is counted (RunAllocatesNothing)
        drives = FakeDrives{};
        drives.controlwords.reserve(100000);
        ROBOT_MODULE_SERVICE = ROBOT_MODULE_SERVICE_t{};
        ROBOT_MODULE_STATE = ROBOT_MODULE_STATE_t{};
        AXIS_OUT = AxesOut{};
        AXIS_IN = AxesIn{};
        IO_STATUS = IO_STATUS_t{};
        drives.position = {0, 0, 0, 0, M_PI / 2, 0};  // home: wrist bent, tool down
        drives.step();
        std::string error;
        module = loadRobot(props, &error);
        ASSERT_TRUE(module) << error;
        run_ = module->runFunction();
        auto loaded = irp::kin::Robot::load(kSet + "/indurop6.urdf");
        ASSERT_TRUE(loaded);
        robot = std::make_unique<irp::kin::Robot>(std::move(loaded).value());
    }
    void TearDown() override {
        if (module) {
            EXPECT_TRUE(module->stop().ok());
        }
        module.reset();
    }

    // One period: drives, then Robot; `after` sees the state block of this period.
    ROBOT_MODULE_STATE_t period() {
        drives.step();
        run_();
        ROBOT_MODULE_STATE_t st = ROBOT_MODULE_STATE;
        states.push_back(st);
        return st;
    }
    ROBOT_MODULE_STATE_t periods(int n) {
        ROBOT_MODULE_STATE_t st{};
        for (int i = 0; i < n; ++i) st = period();
        return st;
    }
    // A request as the PLC writes it (nSeq last).
    uint32_t request(int32_t op, std::array<double, 6> target = {}, double speed = 1.0, double accel = 1.0) {
        ROBOT_MODULE_SERVICE_t s = ROBOT_MODULE_SERVICE;
        s.eOpCode = op;
        s.t_speed = speed;
        s.t_accel = accel;
        for (int i = 0; i < 6; ++i) s.dTarget[i] = target[i];
        s.nSeq = s.nSeq + 1;
        ROBOT_MODULE_SERVICE = s;
        return s.nSeq;
    }
    // Periods until the request `seq` is answered Done or Error (at most `limit`).
    ROBOT_MODULE_STATE_t until(uint32_t seq, int limit = 2000) {
        for (int i = 0; i < limit; ++i) {
            ROBOT_MODULE_STATE_t st = period();
            if (st.nAckSeq == seq && (st.MotionDone == 1 || st.Error == 1)) return st;
        }
        ADD_FAILURE() << "request " << seq << " not answered in " << limit << " periods";
        return ROBOT_MODULE_STATE;
    }
    void powerOn() {
        ROBOT_MODULE_STATE_t st = until(request(1));
        ASSERT_EQ(st.MotionDone, 1);
        ASSERT_EQ(st.Powered, 1);
    }
    static Joints joints(const double (&a)[6]) {
        Joints q;
        for (int i = 0; i < 6; ++i) q[i] = a[i];
        return q;
    }

    Properties props;
    FakeDrives drives;
    std::unique_ptr<irp::hosts::ThreadModule> module;
    void (*run_)() = nullptr;
    std::unique_ptr<irp::kin::Robot> robot;
    std::vector<ROBOT_MODULE_STATE_t> states;
};

const std::array<double, 6> kTargetJ = {0.8, 0.4, -0.5, 0.6, 1.2, -0.7};

}  // namespace

// ---- power ------------------------------------------------------------------------------------------

TEST_F(RobotModule, StartsDisabledFollowingTheDrives) {
    ROBOT_MODULE_STATE_t st = periods(3);
    EXPECT_EQ(st.nAXESGROUP, 6);
    EXPECT_EQ(st.eState, 0);
    EXPECT_EQ(st.Powered, 0);
    EXPECT_EQ(st.Busy, 0);
    EXPECT_EQ(st.dCmdJoint[4], M_PI / 2) << "the command follows the measured joints while disabled";
    EXPECT_EQ(AXIS_OUT[4].position, M_PI / 2);
    EXPECT_EQ(AXIS_OUT[0].mode, 8);
    EXPECT_NEAR(st.dWorldPos[0], 0.55, 1e-12);
    EXPECT_NEAR(st.dWorldPos[2], 0.805, 1e-12);
}

TEST_F(RobotModule, PowerOnSequencesEveryDriveThenAnswersDone) {
    periods(2);
    uint32_t seq = request(1);
    ROBOT_MODULE_STATE_t st = period();
    EXPECT_EQ(st.nAckSeq, seq);
    EXPECT_EQ(st.Busy, 1);
    EXPECT_EQ(st.MotionDone, 0);
    st = until(seq);
    EXPECT_EQ(st.MotionDone, 1);
    EXPECT_EQ(st.Busy, 0);
    EXPECT_EQ(st.Powered, 1);
    EXPECT_EQ(st.eState, 1);
    // Each drive saw shutdown, switch on, enable operation, in that order.
    for (int i = 0; i < 6; ++i) {
        std::vector<uint16_t> seen;
        for (const auto &cws : drives.controlwords)
            if (seen.empty() || seen.back() != cws[i]) seen.push_back(cws[i]);
        std::vector<uint16_t> tail(seen.end() - 3, seen.end());
        EXPECT_EQ(tail, (std::vector<uint16_t>{0x06, 0x07, 0x0F})) << "axis " << i + 1;
    }
    for (int i = 0; i < 6; ++i) EXPECT_EQ(drives.state[i], DS::Enabled);
}

TEST_F(RobotModule, PowerOffSwitchesTheDrivesOff) {
    powerOn();
    ROBOT_MODULE_STATE_t st = until(request(2));
    EXPECT_EQ(st.MotionDone, 1);
    EXPECT_EQ(st.Powered, 0);
    EXPECT_EQ(st.eState, 0);
    for (int i = 0; i < 6; ++i) EXPECT_EQ(drives.state[i], DS::Ready);
}

TEST_F(RobotModule, PowerOnTimesOut) {
    props = {{"power_timeout_ms", "200"}};
    TearDown();
    SetUp();
    drives.deaf[2] = true;
    ROBOT_MODULE_STATE_t st = until(request(1));
    EXPECT_EQ(st.Error, 1);
    EXPECT_EQ(st.ErrorID, 6);
    EXPECT_EQ(st.eState, 4);
    EXPECT_NEAR(states.size() * kDt, 0.2, 0.03);
}

// ---- motions ----------------------------------------------------------------------------------------

TEST_F(RobotModule, MoveJReachesTheTargetWithinTheLimits) {
    powerOn();
    uint32_t seq = request(3, kTargetJ, 0.5, 0.5);
    ROBOT_MODULE_STATE_t st = period();
    EXPECT_EQ(st.nAckSeq, seq);
    EXPECT_EQ(st.Busy, 1);
    size_t first = states.size();
    st = until(seq);
    ASSERT_EQ(st.MotionDone, 1);
    EXPECT_EQ(st.Busy, 0);
    EXPECT_EQ(st.eState, 1);
    for (int i = 0; i < 6; ++i) {
        EXPECT_EQ(st.dCmdJoint[i], kTargetJ[i]);
        EXPECT_EQ(AXIS_OUT[i].position, kTargetJ[i]);
    }
    for (size_t k = first; k + 1 < states.size(); ++k) {
        EXPECT_EQ(states[k].eState, 2) << "period " << k;
        for (int i = 0; i < 6; ++i) {
            double v = (states[k].dCmdJoint[i] - states[k - 1].dCmdJoint[i]) / kDt;
            EXPECT_LE(std::abs(v), 0.5 * robot->limits().velocity[i] + 1e-9);
            EXPECT_LE(std::abs(states[k].dJointSpeed[i]), 0.5 * robot->limits().velocity[i] + 1e-9);
        }
    }
    // dWorldPos is the FK of the commanded joints.
    irp::kin::Pose p = robot->fk(joints(st.dCmdJoint));
    double xyzrpy[6];
    p.toXyzRpy(xyzrpy);
    for (int i = 0; i < 6; ++i) EXPECT_NEAR(st.dWorldPos[i], xyzrpy[i], 1e-12);
    st = period();  // the drives' position reaches AXIS_IN one period after the command
    for (int i = 0; i < 6; ++i) EXPECT_EQ(st.dCurJoint[i], kTargetJ[i]) << "the drives followed";
}

TEST_F(RobotModule, MoveLFollowsTheLine) {
    powerOn();
    ROBOT_MODULE_STATE_t st0 = period();
    std::array<double, 6> target;
    for (int i = 0; i < 6; ++i) target[i] = st0.dWorldPos[i];
    target[1] += 0.3;
    target[2] -= 0.2;
    uint32_t seq = request(4, target, 0.6, 0.5);
    ROBOT_MODULE_STATE_t st = until(seq);
    ASSERT_EQ(st.MotionDone, 1) << "ErrorID " << st.ErrorID;
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(st.dWorldPos[i], target[i], 1e-9);
    for (const auto &s : states) {  // every commanded pose on the line x = const, z = z0 - 2/3 (y - y0)
        EXPECT_NEAR(s.dWorldPos[0], st0.dWorldPos[0], 1e-6);
        EXPECT_NEAR(s.dWorldPos[2] - st0.dWorldPos[2], -2.0 / 3.0 * (s.dWorldPos[1] - st0.dWorldPos[1]), 1e-6);
    }
    for (size_t k = 1; k < states.size(); ++k) {
        double dy = states[k].dWorldPos[1] - states[k - 1].dWorldPos[1],
               dz = states[k].dWorldPos[2] - states[k - 1].dWorldPos[2];
        EXPECT_LE(std::hypot(dy, dz) / kDt, 0.6 * 0.5 + 1e-6) << "max_cart_speed 0.5 m/s at t_speed 0.6";
    }
}

TEST_F(RobotModule, ANewMotionReplacesTheRunningOneAfterStopping) {
    powerOn();
    uint32_t first = request(3, kTargetJ);
    periods(30);
    std::array<double, 6> other = {-0.5, 0.2, 0.1, -0.4, 1.0, 0.5};
    uint32_t second = request(3, other);
    ROBOT_MODULE_STATE_t st = period();
    EXPECT_EQ(st.nAckSeq, second);
    EXPECT_EQ(st.Busy, 1);
    EXPECT_EQ(st.eState, 2);
    st = until(second);
    ASSERT_EQ(st.MotionDone, 1);
    for (int i = 0; i < 6; ++i) EXPECT_EQ(st.dCmdJoint[i], other[i]);
    // No jump in the commanded joints: velocity and acceleration within the limits throughout.
    for (size_t k = 2; k < states.size(); ++k)
        for (int i = 0; i < 6; ++i) {
            double v = (states[k].dCmdJoint[i] - states[k - 1].dCmdJoint[i]) / kDt;
            double a =
                (states[k].dCmdJoint[i] - 2 * states[k - 1].dCmdJoint[i] + states[k - 2].dCmdJoint[i]) / (kDt * kDt);
            EXPECT_LE(std::abs(v), robot->limits().velocity[i] + 1e-9) << "period " << k << " joint " << i + 1;
            EXPECT_LE(std::abs(a), 8.0 + 1e-6) << "period " << k << " joint " << i + 1;
        }
    (void)first;
}

TEST_F(RobotModule, StopDeceleratesThenAnswersDone) {
    powerOn();
    request(3, kTargetJ);
    periods(25);
    uint32_t seq = request(5);
    ROBOT_MODULE_STATE_t st = period();
    EXPECT_EQ(st.nAckSeq, seq);
    EXPECT_EQ(st.eState, 3);
    EXPECT_EQ(st.Busy, 1);
    st = until(seq);
    EXPECT_EQ(st.MotionDone, 1);
    EXPECT_EQ(st.eState, 1);
    for (int i = 0; i < 6; ++i) EXPECT_EQ(st.dJointSpeed[i], 0);
    EXPECT_GT(std::abs(st.dCmdJoint[0] - kTargetJ[0]), 0.05) << "stopped on the way";
    ROBOT_MODULE_STATE_t later = periods(20);
    for (int i = 0; i < 6; ++i) EXPECT_EQ(later.dCmdJoint[i], st.dCmdJoint[i]) << "and stays";
    // A stop at standstill is done at once.
    st = until(request(5), 1);
    EXPECT_EQ(st.MotionDone, 1);
}

TEST_F(RobotModule, PowerOffWhileMovingStopsFirst) {
    powerOn();
    request(3, kTargetJ);
    periods(25);
    uint32_t seq = request(2);
    ROBOT_MODULE_STATE_t st = period();
    EXPECT_EQ(st.eState, 3);
    EXPECT_EQ(st.Powered, 1);
    st = until(seq);
    EXPECT_EQ(st.MotionDone, 1);
    EXPECT_EQ(st.Powered, 0);
    for (size_t k = 2; k < states.size(); ++k)
        for (int i = 0; i < 6; ++i) {
            double a =
                (states[k].dCmdJoint[i] - 2 * states[k - 1].dCmdJoint[i] + states[k - 2].dCmdJoint[i]) / (kDt * kDt);
            EXPECT_LE(std::abs(a), 8.0 + 1e-6);
        }
}

// Op-code 7: a joint velocity motion (MC_MoveVelocity).  MotionDone while it holds the velocity,
// Busy while it runs, until a later request takes over.
TEST_F(RobotModule, MoveVelocityHoldsTheJointVelocitiesUntilAStop) {
    powerOn();
    const std::array<double, 6> v = {0.2, 0, 0, 0, 0, -0.1};
    uint32_t seq = request(7, v, 0.0, 0.5);  // t_speed is not used by op-code 7
    ROBOT_MODULE_STATE_t st = period();
    EXPECT_EQ(st.nAckSeq, seq);
    EXPECT_EQ(st.Busy, 1);
    EXPECT_EQ(st.MotionDone, 0) << "accelerating";
    EXPECT_EQ(st.eState, 2);
    for (int i = 0; i < 200 && st.MotionDone == 0; ++i) st = period();
    ASSERT_EQ(st.MotionDone, 1) << "at the commanded velocity";
    for (int k = 0; k < 20; ++k) {
        ROBOT_MODULE_STATE_t next = period();
        EXPECT_EQ(next.MotionDone, 1);
        EXPECT_EQ(next.Busy, 1) << "still running";
        EXPECT_EQ(next.eState, 2);
        for (int i = 0; i < 6; ++i) {
            EXPECT_NEAR(next.dJointSpeed[i], v[i] * robot->limits().velocity[i], 1e-9) << "joint " << i + 1;
            EXPECT_NEAR((next.dCmdJoint[i] - st.dCmdJoint[i]) / kDt, v[i] * robot->limits().velocity[i], 1e-6);
        }
        st = next;
    }
    uint32_t stop = request(5);
    st = until(stop);
    EXPECT_EQ(st.MotionDone, 1);
    EXPECT_EQ(st.eState, 1);
    EXPECT_EQ(st.Error, 0);
    for (int i = 0; i < 6; ++i) EXPECT_EQ(st.dJointSpeed[i], 0);
}

TEST_F(RobotModule, MoveVelocityStopsAJointAtItsLimitWithErrorID2) {
    powerOn();
    uint32_t seq = request(7, {1, 0, 0, 0, 0, 0});
    ROBOT_MODULE_STATE_t st = period();
    for (int i = 0; i < 1000 && st.Error == 0; ++i) st = period();
    ASSERT_EQ(st.Error, 1);
    EXPECT_EQ(st.ErrorID, 2) << "outside limits, as a PLCopen axis at its software limit";
    EXPECT_EQ(st.nAckSeq, seq);
    EXPECT_EQ(st.eState, 4);
    EXPECT_EQ(st.Powered, 1) << "a controlled stop: the drives stay on";
    EXPECT_NEAR(st.dCmdJoint[0], robot->limits().upper[0], 1e-9) << "stopped at the limit, not past it";
    for (size_t k = 2; k < states.size(); ++k) {
        double a = (states[k].dCmdJoint[0] - 2 * states[k - 1].dCmdJoint[0] + states[k - 2].dCmdJoint[0]) / (kDt * kDt);
        EXPECT_LE(std::abs(a), 8.0 + 1e-6) << "braked within the acceleration limit";
        EXPECT_LE(states[k].dCmdJoint[0], robot->limits().upper[0] + 1e-12);
    }
    until(request(6));
    st = until(request(7, {1, 0, 0, 0, 0, 0}));  // further into the limit: refused at once
    EXPECT_EQ(st.Error, 1);
    EXPECT_EQ(st.ErrorID, 2);
    until(request(6));
    seq = request(7, {-1, 0, 0, 0, 0, 0});  // away from it: accepted
    st = period();
    EXPECT_EQ(st.Error, 0);
    EXPECT_EQ(st.Busy, 1);
    EXPECT_LT(periods(5).dCmdJoint[0], robot->limits().upper[0]);
}

TEST_F(RobotModule, MoveVelocityRefusesFractionsOutsideMinusOneToOneAndAllZero) {
    powerOn();
    for (const std::array<double, 6> &bad :
         {std::array<double, 6>{0, 0, 0, 0, 0, 0}, std::array<double, 6>{0, 1.5, 0, 0, 0, 0},
          std::array<double, 6>{0, 0, std::nan(""), 0, 0, 0}}) {
        ROBOT_MODULE_STATE_t st = until(request(7, bad));
        EXPECT_EQ(st.Error, 1);
        EXPECT_EQ(st.ErrorID, 2);
        until(request(6));
    }
}

// ---- refusals ---------------------------------------------------------------------------------------

TEST_F(RobotModule, MotionRefusedWhenNotPowered) {
    ROBOT_MODULE_STATE_t st = until(request(3, kTargetJ));
    EXPECT_EQ(st.Error, 1);
    EXPECT_EQ(st.ErrorID, 1);
    EXPECT_EQ(st.eState, 4);
    EXPECT_EQ(st.Busy, 0);
    EXPECT_EQ(st.MotionDone, 0);
}

TEST_F(RobotModule, TargetOutsideTheJointLimitsRefused) {
    powerOn();
    std::array<double, 6> bad = kTargetJ;
    bad[2] = 2.0;  // joint 3 stops at 1.25 rad
    ROBOT_MODULE_STATE_t st = until(request(3, bad));
    EXPECT_EQ(st.ErrorID, 2);
    EXPECT_EQ(st.eState, 4);
    st = until(request(3, kTargetJ, 0.0));  // t_speed 0: refused as well (only reset is taken now)
    EXPECT_EQ(st.ErrorID, 2);
    // Reset: back to standstill, powered; then t_speed 0 is refused on its own merit.
    st = until(request(6));
    EXPECT_EQ(st.MotionDone, 1);
    EXPECT_EQ(st.Error, 0);
    EXPECT_EQ(st.eState, 1);
    st = until(request(3, kTargetJ, 0.0));
    EXPECT_EQ(st.ErrorID, 2);
}

TEST_F(RobotModule, UnreachableMoveLRefused) {
    powerOn();
    std::array<double, 6> far = {2.0, 0, 0.8, M_PI, 0, M_PI};
    ROBOT_MODULE_STATE_t st = until(request(4, far));
    EXPECT_EQ(st.Error, 1);
    EXPECT_EQ(st.ErrorID, 3);
}

TEST_F(RobotModule, UnknownOpCodeRefused) {
    ROBOT_MODULE_STATE_t st = until(request(42));
    EXPECT_EQ(st.ErrorID, 7);
    st = until(request(0));
    EXPECT_EQ(st.ErrorID, 7);
}

TEST_F(RobotModule, ARefusedRequestWhileMovingStopsTheRobot) {
    powerOn();
    request(3, kTargetJ);
    periods(25);
    std::array<double, 6> bad = kTargetJ;
    bad[0] = 5.0;
    ROBOT_MODULE_STATE_t st = until(request(3, bad));
    EXPECT_EQ(st.ErrorID, 2);
    st = periods(100);
    for (int i = 0; i < 6; ++i) EXPECT_EQ(st.dJointSpeed[i], 0);
    EXPECT_GT(std::abs(st.dCmdJoint[0] - kTargetJ[0]), 0.05);
    EXPECT_EQ(st.Powered, 1) << "the drives stay on";
}

// ---- faults -----------------------------------------------------------------------------------------

TEST_F(RobotModule, DriveFaultQuickStopsLatchesAndResets) {
    powerOn();
    uint32_t seq = request(3, kTargetJ);
    periods(20);
    drives.state[2] = DS::Fault;
    ROBOT_MODULE_STATE_t st = until(seq);
    EXPECT_EQ(st.Error, 1);
    EXPECT_EQ(st.ErrorID, 4);
    EXPECT_EQ(st.eState, 4);
    period();
    EXPECT_EQ(drives.controlwords.back()[0], 0x02) << "the other drives quick-stop";
    st = periods(3);
    EXPECT_EQ(st.Powered, 0);
    // Motions are refused until a reset.
    st = until(request(3, kTargetJ));
    EXPECT_EQ(st.ErrorID, 4);
    // Reset: a rising edge of bit 7 for the faulted drive, then disabled.
    seq = request(6);
    st = until(seq);
    EXPECT_EQ(st.MotionDone, 1);
    EXPECT_EQ(st.eState, 0);
    EXPECT_EQ(drives.state[2], DS::SwitchOnDisabled);
    bool edge = false;
    for (const auto &cws : drives.controlwords) edge = edge || cws[2] == 0x80;
    EXPECT_TRUE(edge);
    powerOn();
}

TEST_F(RobotModule, PowerOnRefusedWhileADriveIsFaulted) {
    drives.state[5] = DS::Fault;
    ROBOT_MODULE_STATE_t st = until(request(1));
    EXPECT_EQ(st.ErrorID, 4);
    st = until(request(6));
    EXPECT_EQ(st.MotionDone, 1);
    powerOn();
}

TEST_F(RobotModule, FollowingErrorStopsTheRobot) {
    props = {{"following_error", "0.1"}};
    TearDown();
    SetUp();
    powerOn();
    drives.frozen[1] = true;  // joint 2 stops following
    ROBOT_MODULE_STATE_t st = until(request(3, kTargetJ));
    EXPECT_EQ(st.ErrorID, 5);
    EXPECT_EQ(st.eState, 4);
    EXPECT_NEAR(st.dCmdJoint[1], drives.position[1], 1e-12) << "the command falls back to the measured joints";
}

TEST_F(RobotModule, CommunicationLossStopsAndRefusesPowerOn) {
    powerOn();
    uint32_t seq = request(3, kTargetJ);
    periods(10);
    drives.comm_lost = true;
    ROBOT_MODULE_STATE_t st = until(seq);
    EXPECT_EQ(st.ErrorID, 8);
    EXPECT_EQ(st.Powered, 0);
    st = until(request(6));
    EXPECT_EQ(st.MotionDone, 1);
    st = until(request(1));
    EXPECT_EQ(st.ErrorID, 8) << "no power on without the drives";
    drives.comm_lost = false;
    until(request(6));
    powerOn();
}

// ---- the properties and real-time behaviour -----------------------------------------------------------

TEST(RobotModuleProperties, RefusedWithTheirReason) {
    std::string error;
    EXPECT_FALSE(loadRobot({{"urdf", "missing.urdf"}}, &error));
    EXPECT_NE(error.find("property 'urdf': " + kSet + "/missing.urdf: cannot read the URDF"), std::string::npos)
        << error;
    EXPECT_FALSE(loadRobot({{"max_joint_accel", "8,8"}}, &error));
    EXPECT_NE(error.find("property 'max_joint_accel': one value for every joint or 6 values, got 2"), std::string::npos)
        << error;
    EXPECT_FALSE(loadRobot({{"max_cart_speed", "-1"}}, &error));
    EXPECT_NE(error.find("property 'max_cart_speed': must be a positive number"), std::string::npos) << error;
    EXPECT_FALSE(loadRobot({{"tip_link", "link_5"}}, &error));
    EXPECT_NE(error.find("has 5 movable joints"), std::string::npos) << error;
    EXPECT_FALSE(loadRobot({{"drive_devices", "9"}}, &error));
    EXPECT_NE(error.find("property 'drive_devices'"), std::string::npos) << error;
}

TEST_F(RobotModule, RunAllocatesNothing) {
    // Every path of run(): power on, MoveJ, MoveL, replacement, stop, refusals, a fault, reset.
    AllocationCounter counter;
    powerOn();
    request(3, kTargetJ);
    periods(20);
    ROBOT_MODULE_STATE_t st = period();
    std::array<double, 6> pose;
    for (int i = 0; i < 6; ++i) pose[i] = st.dWorldPos[i];
    pose[0] -= 0.1;
    request(4, pose);
    periods(10);
    request(3, {-0.5, 0.2, 0.1, -0.4, 1.0, 0.5});
    periods(10);
    request(5);
    periods(50);
    request(7, {0.3, -0.2, 0, 0, 0, 0});
    periods(30);
    request(5);
    periods(50);
    request(3, {9, 9, 9, 9, 9, 9});
    periods(2);
    until(request(6));
    drives.state[0] = DS::Fault;
    periods(3);
    until(request(6));
    powerOn();
    EXPECT_EQ(counter.count(), 0);
    EXPECT_GT(states.size(), 100u);
}
