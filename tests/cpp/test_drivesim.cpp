// test_drivesim.cpp -- the drive simulator: its axis model stepped directly (limits at every
// step, the CiA 402 transitions), and the real indurop-drivesim process over Modbus TCP on
// loopback (register map, power-up to operation enabled, CSP motion within its limits,
// following-error fault and fault reset, quick stop, fault injection, several clients,
// --fail-after / --fail-for, a clean exit on SIGTERM, refused options).
#include "axis.hpp"
#include "register_map.hpp"
#include "support/drivesim.hpp"

#include <gtest/gtest.h>

#include <sched.h>

#include <cmath>

using namespace irp::drivesim;
using testing_support::DriveSim;
using testing_support::eventually;
using testing_support::ModbusClient;

namespace {

constexpr double kCpr = 100000;  // the simulator's default counts per rad

int holding(int axis, int reg) { return regs::kHoldingStride * axis + reg; }
int input(int axis, int reg) { return regs::kInputStride * axis + reg; }

uint16_t state(uint16_t statusword) { return statusword & 0x6F; }
bool switchOnDisabled(uint16_t statusword) { return (statusword & 0x4F) == 0x40; }

// A new axis to operation enabled: its first step leaves "not ready to switch on", then one
// command per step.
void powerUp(Axis &a) {
    a.step(0.001);
    for (uint16_t c : {0x06, 0x07, 0x0F}) {
        a.setControlword(c);
        a.step(0.001);
    }
}

// Brings one axis of the simulator to operation enabled in CSP, its target at its actual position.
void enable(ModbusClient &c, int axis) {
    c.write32(holding(axis, regs::kTargetPosition), c.input32(input(axis, regs::kActualPosition)));
    c.write(holding(axis, regs::kModeOfOperation), {8});
    c.write(holding(axis, regs::kControlword), {0x06});
    ASSERT_TRUE(eventually([&] { return state(c.input1(input(axis, regs::kStatusword))) == 0x21; }));
    c.write(holding(axis, regs::kControlword), {0x07});
    ASSERT_TRUE(eventually([&] { return state(c.input1(input(axis, regs::kStatusword))) == 0x23; }));
    c.write(holding(axis, regs::kControlword), {0x0F});
    ASSERT_TRUE(eventually([&] { return state(c.input1(input(axis, regs::kStatusword))) == 0x27; }));
}

}  // namespace

// ---- the axis model, stepped directly ----------------------------------------------------------

TEST(DriveAxis, PowersUpThroughTheCia402States) {
    Axis a;
    a.step(0.001);
    EXPECT_TRUE(switchOnDisabled(a.statusword())) << std::hex << a.statusword();
    a.setControlword(0x06);
    a.step(0.001);
    EXPECT_EQ(state(a.statusword()), 0x21);
    a.setControlword(0x07);
    a.step(0.001);
    EXPECT_EQ(state(a.statusword()), 0x23);
    a.setControlword(0x0F);
    a.step(0.001);
    EXPECT_EQ(state(a.statusword()), 0x27);
    a.setControlword(0x07);  // disable operation
    a.step(0.001);
    EXPECT_EQ(state(a.statusword()), 0x23);
    a.setControlword(0x00);  // disable voltage
    a.step(0.001);
    EXPECT_TRUE(switchOnDisabled(a.statusword()));
}

TEST(DriveAxis, SwitchOnWithEnableOperationGoesOnToOperationEnabled) {
    Axis a;
    a.step(0.001);
    a.setControlword(0x06);
    a.step(0.001);
    a.setControlword(0x0F);  // transitions 3 and 4
    a.step(0.001);
    EXPECT_EQ(state(a.statusword()), 0x23);
    a.step(0.001);
    EXPECT_EQ(state(a.statusword()), 0x27);
}

TEST(DriveAxis, CommandsThatDoNotApplyLeaveTheStateAlone) {
    Axis a;
    a.step(0.001);
    a.setControlword(0x0F);  // enable operation from switch on disabled: not a transition
    a.step(0.001);
    EXPECT_TRUE(switchOnDisabled(a.statusword()));
    a.setControlword(0x07);
    a.step(0.001);
    EXPECT_TRUE(switchOnDisabled(a.statusword()));
}

TEST(DriveAxis, VelocityAndAccelerationLimitsHoldAtEveryStep) {
    AxisParams p;
    p.max_velocity = 2 * kCpr;
    p.max_acceleration = 20 * kCpr;
    p.following_limit = 10 * kCpr;  // let a 1 rad step through
    Axis a(p);
    a.setMode(8);
    powerUp(a);
    ASSERT_EQ(state(a.statusword()), 0x27);
    a.setTarget(static_cast<int32_t>(1 * kCpr));
    double v_prev = 0, v_peak = 0;
    for (int k = 0; k < 2000; ++k) {
        const double x0 = a.exactPosition();
        a.step(0.001);
        const double v = (a.exactPosition() - x0) / 0.001;
        EXPECT_LE(std::abs(v), p.max_velocity * (1 + 1e-9)) << "step " << k;
        EXPECT_LE(std::abs(v - v_prev), p.max_acceleration * 0.001 * (1 + 1e-9)) << "step " << k;
        v_peak = std::max(v_peak, std::abs(v));
        v_prev = v;
    }
    EXPECT_GT(v_peak, 0.9 * p.max_velocity);  // the limit, not the lag, set the pace
    EXPECT_NEAR(a.position(), 1 * kCpr, 1);
    EXPECT_TRUE(a.statusword() & sw::kTargetReached);
    EXPECT_EQ(a.errorCode(), 0);
}

TEST(DriveAxis, FollowsARampWithASmallLag) {
    Axis a;  // lag 4 ms
    a.setMode(8);
    powerUp(a);
    // 1 rad/s for 0.5 s, new targets every 10 ms as a 10 ms controller would send them.
    double worst = 0;
    for (int k = 1; k <= 500; ++k) {
        if (k % 10 == 0) a.setTarget(static_cast<int32_t>(k * 0.001 * kCpr));
        a.step(0.001);
        if (k > 100) worst = std::max(worst, std::abs(a.followingError()));
    }
    EXPECT_LT(worst, 0.02 * kCpr);  // well inside the 0.1 rad following-error limit
    EXPECT_EQ(state(a.statusword()), 0x27);
}

TEST(DriveAxis, FollowingErrorFaultsAndFaultResetClearsIt) {
    Axis a;
    a.setMode(8);
    powerUp(a);
    a.setTarget(static_cast<int32_t>(0.5 * kCpr));  // a jump: the limit is 0.1 rad
    for (int k = 0; k < 1000 && !(a.statusword() & sw::kFault); ++k) a.step(0.001);
    for (int k = 0; k < 1000 && a.state() != State::Fault; ++k) a.step(0.001);
    EXPECT_EQ(a.statusword() & 0x4F, 0x08);
    EXPECT_EQ(a.errorCode(), kErrorFollowing);
    EXPECT_TRUE(a.statusword() & sw::kFollowingError);
    a.setControlword(0x80);  // rising edge of bit 7 ...
    a.setControlword(0x00);  // ... taken even if bit 7 falls before the next step
    a.step(0.001);
    EXPECT_TRUE(switchOnDisabled(a.statusword()));
    EXPECT_EQ(a.errorCode(), 0);
    EXPECT_FALSE(a.statusword() & sw::kFollowingError);
}

TEST(DriveAxis, QuickStopBrakesAndStaysUntilEnabledOrDisabled) {
    AxisParams p;
    p.following_limit = 10 * kCpr;
    Axis a(p);
    a.setMode(8);
    powerUp(a);
    a.setTarget(static_cast<int32_t>(3 * kCpr));
    for (int k = 0; k < 100; ++k) a.step(0.001);
    ASSERT_GT(std::abs(a.velocity()), 0);
    a.setControlword(0x02);
    a.step(0.001);
    EXPECT_EQ(state(a.statusword()), 0x07);
    for (int k = 0; k < 1000 && a.velocity() != 0; ++k) a.step(0.001);
    EXPECT_EQ(a.velocity(), 0);
    EXPECT_EQ(state(a.statusword()), 0x07);  // option code 6: stays in quick stop active
    a.setControlword(0x00);
    a.step(0.001);
    EXPECT_TRUE(switchOnDisabled(a.statusword()));
}

// ---- the simulator process over Modbus TCP --------------------------------------------------

TEST(DriveSim, PublishesItsRegisterMap) {
    DriveSim sim({"--axes", "4"});
    ModbusClient c(sim.port());
    EXPECT_EQ(c.input1(regs::kAxisCount), 4);
    EXPECT_EQ(c.input1(regs::kMapVersion), regs::kMapVersionValue);
    const auto t0 = static_cast<uint32_t>(c.input32(regs::kSimTimeMs));
    EXPECT_TRUE(eventually([&] { return static_cast<uint32_t>(c.input32(regs::kSimTimeMs)) > t0 + 5; }));  // it steps
    for (int i = 0; i < 4; ++i) EXPECT_TRUE(switchOnDisabled(c.input1(input(i, regs::kStatusword))));
    // Loopback: holding -> input registers, coils -> discrete inputs.
    c.write(regs::kLoopback + 3, {0xBEEF});
    EXPECT_EQ(c.input1(regs::kLoopback + 3), 0xBEEF);
    uint8_t on = 1, back = 0;
    ASSERT_EQ(modbus_write_bit(c.ctx(), 5, on), 1);
    ASSERT_EQ(modbus_read_input_bits(c.ctx(), 5, 1, &back), 1);
    EXPECT_EQ(back, 1);
}

TEST(DriveSim, StateMachineReachesOperationEnabled) {
    DriveSim sim;
    ModbusClient c(sim.port());
    enable(c, 2);
    EXPECT_EQ(c.input1(input(2, regs::kModeDisplay)), 8);
    EXPECT_TRUE(c.input1(input(2, regs::kStatusword)) & sw::kFollowsTarget);
    EXPECT_TRUE(switchOnDisabled(c.input1(input(1, regs::kStatusword))));  // the others did not move
}

TEST(DriveSim, PositionFollowsTheTargetWithinItsLimits) {
    DriveSim sim({"--max-velocity", "2", "--max-acceleration", "20", "--following-limit", "3"});
    ModbusClient c(sim.port());
    enable(c, 0);
    c.write32(holding(0, regs::kTargetPosition), static_cast<int32_t>(1 * kCpr));
    int32_t peak = 0;
    ASSERT_TRUE(eventually([&] {
        peak = std::max(peak, std::abs(c.input32(input(0, regs::kActualVelocity))));
        return (c.input1(input(0, regs::kStatusword)) & sw::kTargetReached) &&
               std::abs(c.input32(input(0, regs::kActualPosition)) - 1 * kCpr) <= 50;
    }));
    EXPECT_LE(peak, 2 * kCpr + 1);
    EXPECT_GT(peak, 1.0 * kCpr);  // it really moved at speed
    EXPECT_NEAR(c.input32(input(0, regs::kActualPosition)), 1 * kCpr, 50);
    EXPECT_EQ(c.input1(input(0, regs::kErrorCode)), 0);
    EXPECT_EQ(state(c.input1(input(0, regs::kStatusword))), 0x27);
}

TEST(DriveSim, FollowingErrorFaultsAndFaultResetRecovers) {
    DriveSim sim;  // following limit 0.1 rad
    ModbusClient c(sim.port());
    enable(c, 1);
    c.write32(holding(1, regs::kTargetPosition), static_cast<int32_t>(0.5 * kCpr));
    ASSERT_TRUE(eventually([&] { return (c.input1(input(1, regs::kStatusword)) & 0x4F) == 0x08; }));
    EXPECT_EQ(c.input1(input(1, regs::kErrorCode)), kErrorFollowing);
    EXPECT_TRUE(c.input1(input(1, regs::kStatusword)) & sw::kFollowingError);
    c.write(holding(1, regs::kControlword), {0x80});
    ASSERT_TRUE(eventually([&] { return switchOnDisabled(c.input1(input(1, regs::kStatusword))); }));
    EXPECT_EQ(c.input1(input(1, regs::kErrorCode)), 0);
    c.write(holding(1, regs::kControlword), {0x00});
    enable(c, 1);  // takes the actual position as target first: no new fault
    EXPECT_EQ(c.input1(input(1, regs::kErrorCode)), 0);
}

TEST(DriveSim, QuickStopAndFaultInjection) {
    DriveSim sim;
    ModbusClient c(sim.port());
    enable(c, 3);
    c.write(holding(3, regs::kControlword), {0x02});
    ASSERT_TRUE(eventually([&] { return state(c.input1(input(3, regs::kStatusword))) == 0x07; }));
    c.write(regs::kFaultInjection, {1u << 4});
    ASSERT_TRUE(eventually([&] { return (c.input1(input(4, regs::kStatusword)) & 0x4F) == 0x08; }));
    EXPECT_EQ(c.input1(input(4, regs::kErrorCode)), kErrorInjected);
    EXPECT_EQ(c.holding(regs::kFaultInjection, 1)[0], 0);  // consumed
}

TEST(DriveSim, AnswersSeveralClients) {
    DriveSim sim;
    ModbusClient a(sim.port()), b(sim.port());
    a.write(regs::kLoopback, {11});
    b.write(regs::kLoopback + 1, {22});
    EXPECT_EQ(b.input1(regs::kLoopback), 11);
    EXPECT_EQ(a.input1(regs::kLoopback + 1), 22);
}

TEST(DriveSim, FailAfterStopsAnsweringAndFailForResumes) {
    DriveSim sim({"--fail-after", "0.3", "--fail-for", "1.5"});
    ModbusClient c(sim.port(), 0.2);
    uint16_t r;
    int failure = 0;
    ASSERT_TRUE(eventually([&] {
        if (modbus_read_input_registers(c.ctx(), regs::kAxisCount, 1, &r) == 1) return false;
        failure = errno;
        return true;
    }));
    EXPECT_EQ(failure, ETIMEDOUT) << modbus_strerror(failure);
    EXPECT_TRUE(eventually([&] { return sim.out().find("no longer answering") != std::string::npos; }));
    // After --fail-for it answers again (a new connection: the old one holds stale requests).
    ASSERT_TRUE(eventually([&] { return sim.out().find("answering again") != std::string::npos; }));
    ModbusClient again(sim.port());
    EXPECT_EQ(again.input1(regs::kAxisCount), 6);
}

// The drive's fieldbus watchdog: the master's writes feed it; silence for --comm-timeout makes
// every axis quick-stop and fault (0x8130); a fault reset recovers it.
TEST(DriveSim, CommTimeoutQuickStopsAndFaultsEveryAxisAndFaultResetRecovers) {
    // 500 ms: room for this test's own stalls between its writes on a loaded machine
    DriveSim sim({"--comm-timeout", "500"});
    ModbusClient c(sim.port());
    enable(c, 0);  // each write feeds the watchdog
    // The master goes silent (this client only reads from now on): the enabled axis quick-stops
    // into fault, and so does every other axis.
    ASSERT_TRUE(eventually([&] { return (c.input1(input(0, regs::kStatusword)) & 0x4F) == 0x08; }));
    EXPECT_EQ(c.input1(input(0, regs::kErrorCode)), kErrorCommTimeout);
    EXPECT_EQ(c.input32(input(0, regs::kActualVelocity)), 0);
    const int32_t stopped_at = c.input32(input(0, regs::kActualPosition));
    for (int axis = 1; axis < 6; ++axis) {
        EXPECT_TRUE(eventually([&] { return (c.input1(input(axis, regs::kStatusword)) & 0x4F) == 0x08; })) << axis;
        EXPECT_EQ(c.input1(input(axis, regs::kErrorCode)), kErrorCommTimeout) << axis;
    }
    EXPECT_NE(sim.out().find("comm timeout: no write for"), std::string::npos) << sim.out();
    // The master writes again: still in fault (a fault is latched) until the fault reset.
    c.write32(holding(0, regs::kTargetPosition), stopped_at);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_EQ((c.input1(input(0, regs::kStatusword)) & 0x4F), 0x08);
    c.write(holding(0, regs::kControlword), {0x80});
    ASSERT_TRUE(eventually([&] { return switchOnDisabled(c.input1(input(0, regs::kStatusword))); }));
    EXPECT_EQ(c.input1(input(0, regs::kErrorCode)), 0);
    c.write(holding(0, regs::kControlword), {0x00});
    enable(c, 0);
}

TEST(DriveSim, NoCommWatchdogBeforeTheFirstWriteNorWithCommTimeoutZero) {
    for (const char *timeout : {"50", "0"}) {
        DriveSim sim({"--comm-timeout", timeout});
        ModbusClient c(sim.port());
        if (std::string(timeout) == "0") c.write(holding(0, regs::kControlword), {0x00});  // armed, were it on
        // Reads only, for six times the timeout: no fault anywhere.
        const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(300);
        while (std::chrono::steady_clock::now() < end) {
            EXPECT_EQ(c.input1(input(0, regs::kStatusword)) & sw::kFault, 0) << timeout;
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        EXPECT_EQ(sim.out().find("comm timeout"), std::string::npos) << sim.out();
    }
}

TEST(DriveSim, ExitsCleanlyOnSigterm) {
    DriveSim sim;
    { ModbusClient c(sim.port()); }
    EXPECT_EQ(sim.stop(SIGTERM), 0);
    EXPECT_NE(sim.out().find("indurop-drivesim: stopped"), std::string::npos) << sim.out();
}

// A drive answers from a CPU of its own; --rt-priority gives the simulator the nearest thing on a
// shared machine.  Where SCHED_FIFO is not permitted it says so and answers as a normal process.
TEST(DriveSim, RtPriorityRunsItAtSchedFifoOrSaysWhyNot) {
    DriveSim sim({"--rt-priority", "7"});
    ModbusClient c(sim.port());
    c.write(regs::kLoopback, {5});
    EXPECT_EQ(c.input1(regs::kLoopback), 5);
    sched_param param{};
    if (sched_getscheduler(sim.pid()) == SCHED_FIFO) {
        ASSERT_EQ(sched_getparam(sim.pid(), &param), 0);
        EXPECT_EQ(param.sched_priority, 7);
        EXPECT_EQ(sim.err().find("--rt-priority"), std::string::npos) << sim.err();
    } else {
        EXPECT_NE(sim.err().find("--rt-priority 7: "), std::string::npos) << sim.err();
        EXPECT_NE(sim.err().find("running as a normal process"), std::string::npos) << sim.err();
    }
}

TEST(DriveSim, RefusesBadOptions) {
    for (const std::vector<std::string> &args : std::vector<std::vector<std::string>>{{"--axes", "0"},
                                                                                      {"--axes", "33"},
                                                                                      {"--host", "localhost"},
                                                                                      {"--max-velocity", "1,2"},
                                                                                      {"--rt-priority", "0"},
                                                                                      {"--rt-priority", "100"},
                                                                                      {"--bogus"}}) {
        testing_support::TempDir dir;
        std::vector<std::string> argv{DRIVESIM_PATH, "--port", "0"};
        argv.insert(argv.end(), args.begin(), args.end());
        testing_support::Process p(argv, dir.path);
        EXPECT_EQ(p.wait(), 2) << args[0];
        EXPECT_NE(p.err().find("usage:"), std::string::npos) << p.err();
    }
}
