// test_iodispat.cpp -- the I/O dispatcher against real Modbus peers, with a real shared-variable
// segment of the plc-robot cell (cell.glb):
//   - Modbus TCP against indurop-drivesim, libiodispat.so loaded through irpd's loader: the demo
//     config round trip for six axes (CiA 402 to operation enabled, targets and positions in rad),
//     every encoding through the simulator's loopback registers, comm loss when the simulator
//     dies (flag in the same cycle, inputs to their defaults, run() bounded, safe outputs written
//     first when it answers again), a silent simulator (--fail-after) against fail_limit, the budget;
//   - Modbus RTU over a pseudo-terminal.
// ioconfig.xml, the encodings and the paths: test_ioconfig.cpp; CAN: test_iodispat_can.cpp.
#include "dispatcher.hpp"
#include "ioconfig.hpp"
#include "modbus_device.hpp"

#include "hosts/thread_module.hpp"
#include "support/drivesim.hpp"
#include "support/iodispat.hpp"
#include "support/iodispat_module.hpp"

#include <indurop/generated.h>  // the plc-robot cell's variables (PLC_ROBOT::...)
#include <indurop/indurop.h>

#include <gtest/gtest.h>

#include <pty.h>
#include <sys/select.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <thread>

using namespace irp;
using namespace irp::iodispat;
using PLC_ROBOT::AXIS_IN;
using PLC_ROBOT::AXIS_OUT;
using PLC_ROBOT::IO_STATUS;
using testing_support::cyclesUntil;
using testing_support::demoConfig;
using testing_support::DriveSim;
using testing_support::LoadedModule;
using testing_support::ModbusClient;
using testing_support::readFile;
using testing_support::resetVariables;
using testing_support::state;
using testing_support::TempDir;
using testing_support::writeFile;

namespace {

constexpr double kCpr = 100000;  // the simulator's default counts per rad; the demo scales by 1e-5

}  // namespace

// ---- Modbus TCP against the drive simulator -----------------------------------------------------

TEST(IoDispatModbus, DemoConfigDrivesTheSixAxes) {
    resetVariables();
    DriveSim sim({"--quiet"});
    TempDir dir;
    LoadedModule io;
    ASSERT_EQ(io.load(writeFile(dir, "ioconfig.xml",
                                demoConfig(sim.port(), R"(timeout_ms="200" fail_limit="3" reconnect_ms="100")"))),
              "");
    auto run = [&] { io.run(); };
    ASSERT_TRUE(cyclesUntil(run, [] { return IO_STATUS.comm_lost[0] == 0 && (AXIS_IN[5].statusword & 0x4F) == 0x40; }));

    // CiA 402 power-up of all six through the shared variables, CSP, targets at the actual positions.
    for (int i = 0; i < 6; ++i) {
        AXIS_OUT[i].mode = 8;
        AXIS_OUT[i].position = static_cast<double>(AXIS_IN[i].position);
        AXIS_OUT[i].controlword = 0x06;
    }
    auto all = [](uint16_t s) {
        for (int i = 0; i < 6; ++i)
            if (state(AXIS_IN[i].statusword) != s) return false;
        return true;
    };
    ASSERT_TRUE(cyclesUntil(run, [&] { return all(0x21); }));
    for (int i = 0; i < 6; ++i) AXIS_OUT[i].controlword = 0x07;
    ASSERT_TRUE(cyclesUntil(run, [&] { return all(0x23); }));
    for (int i = 0; i < 6; ++i) AXIS_OUT[i].controlword = 0x0F;
    ASSERT_TRUE(cyclesUntil(run, [&] { return all(0x27); }));
    for (int i = 0; i < 6; ++i) EXPECT_EQ(static_cast<int8_t>(AXIS_IN[i].mode), 8);

    // A target in rad reaches the drive in counts; the position comes back in rad.
    AXIS_OUT[2].position = 0.05;
    AXIS_OUT[4].position = -0.03;
    ASSERT_TRUE(cyclesUntil(run, [] {
        return std::abs(AXIS_IN[2].position - 0.05) < 1e-4 && std::abs(AXIS_IN[4].position + 0.03) < 1e-4;
    }));
    ModbusClient c(sim.port());
    EXPECT_EQ(c.holding32(4 * 2 + 2), 5000);
    EXPECT_EQ(c.holding32(4 * 4 + 2), -3000);
    EXPECT_NEAR(c.input32(8 * 2 + 3) / kCpr, AXIS_IN[2].position, 1e-3);  // moving little by now
    EXPECT_EQ(IO_STATUS.comm_lost[0], 0);
    EXPECT_EQ(IO_STATUS.errors[0], 0u);
    EXPECT_GT(IO_STATUS.cycles, 10u);
    EXPECT_GE(IO_STATUS.last_cycle_us, 0);
}

TEST(IoDispatModbus, DemoConfigIsTwoTransactionsPerCycle) {
    resetVariables();
    DriveSim sim({"--quiet"});
    Dispatcher d(parseIoConfigText(demoConfig(sim.port()), "ioconfig.xml"));
    d.start();
    const auto &m = dynamic_cast<const ModbusDevice &>(d.device(0));
    EXPECT_EQ(m.inputBlocks(), 1u);   // input registers 0..47 (the unmapped 8i+7 read along)
    EXPECT_EQ(m.outputBlocks(), 1u);  // holding registers 0..23
    std::string strict = demoConfig(sim.port());
    strict.replace(strict.find("unit=\"1\""), 8, "unit=\"1\" read_gap=\"0\"");
    Dispatcher e(parseIoConfigText(strict, "ioconfig.xml"));
    e.start();
    EXPECT_EQ(dynamic_cast<const ModbusDevice &>(e.device(0)).inputBlocks(), 6u);  // one per axis
}

namespace {

// Axis 0 of the simulator plus loopback registers, with the given device settings and extras.
std::string driveConfig(int port, const std::string &settings, const std::string &extra = "",
                        const std::string &root = "") {
    return R"(<ioconfig status="PLC_ROBOT.IO_STATUS")" + root + R"(>
  <device name="drives" type="modbus-tcp" host="127.0.0.1" port=")" +
           std::to_string(port) + "\" " + settings + R"(>
    <input  table="input"   address="0" type="u16" path="PLC_ROBOT.AXIS_IN[0].statusword"/>
    <input  table="input"   address="1" type="u16" path="PLC_ROBOT.AXIS_IN[0].error" default="65535"/>
    <input  table="input"   address="3" type="s32" path="PLC_ROBOT.AXIS_IN[0].position" scale="1e-5"/>
    <output table="holding" address="0" type="u16" path="PLC_ROBOT.AXIS_OUT[0].controlword" safe="0"/>
    <output table="holding" address="2" type="s32" path="PLC_ROBOT.AXIS_OUT[0].position" scale="1e-5" safe="hold"/>
    <output table="holding" address="520" type="s16" path="PLC_ROBOT.PLC_OUT.Step" safe="1234"/>
)" + extra +
           R"(
  </device>
</ioconfig>
)";
}

}  // namespace

TEST(IoDispatModbus, EveryEncodingAndScalingThroughTheLoopback) {
    resetVariables();
    DriveSim sim({"--quiet"});
    TempDir dir;
    const std::string extra = R"(
    <output table="holding" address="512" type="f32" words="low-first" path="PLC_ROBOT.ROBOT_MODULE_SERVICE.dTarget[0]"/>
    <input  table="input"   address="512" type="f32" words="low-first" path="PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[0]"/>
    <output table="holding" address="514" type="s32" path="PLC_ROBOT.ROBOT_MODULE_SERVICE.dTarget[1]" scale="0.001" offset="10"/>
    <input  table="input"   address="514" type="s32" path="PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[1]" scale="0.001" offset="10"/>
    <output table="holding" address="516" type="s16" path="PLC_ROBOT.PLC_OUT.ErrorID"/>
    <input  table="input"   address="516" type="s16" path="PLC_ROBOT.ROBOT_MODULE_STATE.ErrorID"/>
    <output table="holding" address="517" type="u32" path="PLC_ROBOT.PLC_OUT.Cycles"/>
    <input  table="input"   address="517" type="u32" path="PLC_ROBOT.ROBOT_MODULE_STATE.nAckSeq"/>
    <output table="holding" address="519" type="u16" path="PLC_ROBOT.ROBOT_MODULE_SERVICE.dTarget[2]"/>
    <input  table="input"   address="519" type="u16" path="PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[2]"/>
    <output table="coil"    address="3" path="PLC_ROBOT.PLC_IN.Start"/>
    <input  table="discrete" address="3" path="PLC_ROBOT.PLC_OUT.Running"/>)";
    LoadedModule io;
    ASSERT_EQ(io.load(writeFile(dir, "io.xml", driveConfig(sim.port(), R"(timeout_ms="200")", extra))), "");
    PLC_ROBOT::ROBOT_MODULE_SERVICE.dTarget[0] = -1.25;
    PLC_ROBOT::ROBOT_MODULE_SERVICE.dTarget[1] = 7.5;  // raw (7.5 - 10) / 0.001 = -2500
    PLC_ROBOT::PLC_OUT.ErrorID = -321;
    PLC_ROBOT::PLC_OUT.Cycles = 3000000000u;
    PLC_ROBOT::ROBOT_MODULE_SERVICE.dTarget[2] = -5;  // clamped to 0 by u16
    PLC_ROBOT::PLC_IN.Start = 1;
    auto run = [&] { io.run(); };
    ASSERT_TRUE(cyclesUntil(
        run, [] { return PLC_ROBOT::ROBOT_MODULE_STATE.nAckSeq == 3000000000u && PLC_ROBOT::PLC_OUT.Running == 1; }));
    EXPECT_EQ(PLC_ROBOT::ROBOT_MODULE_STATE.dCurJoint[0], -1.25);
    EXPECT_NEAR(PLC_ROBOT::ROBOT_MODULE_STATE.dCurJoint[1], 7.5, 1e-9);
    EXPECT_EQ(PLC_ROBOT::ROBOT_MODULE_STATE.ErrorID, -321);
    EXPECT_EQ(PLC_ROBOT::ROBOT_MODULE_STATE.dCurJoint[2], 0);
    ModbusClient c(sim.port());
    const auto f = c.holding(512, 2);
    EXPECT_EQ(f[0], 0x0000);  // -1.25f = 0xBFA00000, low word first
    EXPECT_EQ(f[1], 0xBFA0);
    EXPECT_EQ(c.holding32(514), -2500);
    EXPECT_EQ(c.holding(516, 1)[0], static_cast<uint16_t>(-321));
    EXPECT_EQ(static_cast<uint32_t>(c.holding32(517)), 3000000000u);
    EXPECT_EQ(c.holding(519, 1)[0], 0);
}

TEST(IoDispatModbus, CommLostInTheSameCycleWhenTheSimulatorDiesAndSafeOutputsFirstWhenItReturns) {
    resetVariables();
    auto sim = std::make_unique<DriveSim>(std::vector<std::string>{"--quiet"});
    const int port = sim->port();
    TempDir dir;
    const double timeout_ms = 50;
    LoadedModule io;
    ASSERT_EQ(
        io.load(writeFile(dir, "io.xml", driveConfig(port, R"(timeout_ms="50" fail_limit="3" reconnect_ms="200")"))),
        "");
    auto run = [&] { io.run(); };
    PLC_ROBOT::PLC_OUT.Step = 77;
    AXIS_OUT[0].position = 0.03;
    AXIS_OUT[0].controlword = 0x06;
    {
        ModbusClient c(port);
        ASSERT_TRUE(cyclesUntil(
            run, [&] { return c.holding(520, 1)[0] == 77 && c.holding32(2) == 3000 && c.holding(0, 1)[0] == 6; }));
    }
    ASSERT_EQ(IO_STATUS.comm_lost[0], 0);
    ASSERT_NE(static_cast<uint16_t>(AXIS_IN[0].error), 65535);

    // The simulator dies: the next cycle has the flag, and the inputs their defaults.
    ASSERT_EQ(sim->stop(SIGKILL), -2);
    sim.reset();
    io.run();
    EXPECT_EQ(IO_STATUS.comm_lost[0], 1);
    EXPECT_EQ(static_cast<uint16_t>(AXIS_IN[0].error), 65535);
    EXPECT_GE(IO_STATUS.errors[0], 1u);

    // Without a device, run() stays bounded (connect attempts every 200 ms, each refused or timed out).
    std::chrono::nanoseconds longest{0};
    for (int k = 0; k < 60; ++k) {
        longest = std::max(longest, io.run());
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    EXPECT_LT(longest, std::chrono::microseconds(static_cast<int64_t>(3 * timeout_ms * 1000)));
    EXPECT_EQ(IO_STATUS.comm_lost[0], 1);

    // It comes back on the same port: the round that finds it writes the safe values (controlword
    // 0, Step 1234) and holds the target; the next one the variables again.
    DriveSim again({"--quiet"}, port);
    ModbusClient c(port);
    ASSERT_TRUE(cyclesUntil(run, [] { return IO_STATUS.comm_lost[0] == 0; }));
    EXPECT_EQ(c.holding(520, 1)[0], 1234);
    EXPECT_EQ(c.holding(0, 1)[0], 0);
    EXPECT_EQ(c.holding32(2), 3000);
    io.run();
    EXPECT_EQ(c.holding(520, 1)[0], 77);
    EXPECT_EQ(c.holding(0, 1)[0], 6);
    EXPECT_NE(static_cast<uint16_t>(AXIS_IN[0].error), 65535);
}

namespace {

// A silent simulator (--fail-after): the flag must come exactly with the fail_limit-th failed
// cycle in a row, and every run() stay under 3 x the timeout.
void silentDevice(int fail_limit) {
    resetVariables();
    DriveSim sim({"--quiet", "--fail-after", "0.5", "--fail-for", "1.5"});
    TempDir dir;
    const int timeout_ms = 50;
    LoadedModule io;
    ASSERT_EQ(
        io.load(writeFile(dir, "io.xml",
                          driveConfig(sim.port(), "timeout_ms=\"" + std::to_string(timeout_ms) + "\" fail_limit=\"" +
                                                      std::to_string(fail_limit) + "\" reconnect_ms=\"200\""))),
        "");
    auto run = [&] { io.run(); };
    ASSERT_TRUE(cyclesUntil(run, [] { return IO_STATUS.comm_lost[0] == 0; }));
    const uint32_t errors_before = IO_STATUS.errors[0];
    std::chrono::nanoseconds longest{0};
    bool flagged = false;
    for (int k = 0; k < 500 && !flagged; ++k) {
        longest = std::max(longest, io.run());
        const uint32_t failed = IO_STATUS.errors[0] - errors_before;
        if (failed < static_cast<uint32_t>(fail_limit)) {
            ASSERT_EQ(IO_STATUS.comm_lost[0], 0) << "cycle " << k << ", " << failed << " failures";
        } else {
            ASSERT_EQ(failed, static_cast<uint32_t>(fail_limit)) << "the flag is late";
            ASSERT_EQ(IO_STATUS.comm_lost[0], 1) << "cycle " << k << ", " << failed << " failures";
            flagged = true;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ASSERT_TRUE(flagged);
    EXPECT_EQ(static_cast<uint16_t>(AXIS_IN[0].error), 65535);
    // Reconnect attempts while it stays silent: still bounded.
    for (int k = 0; k < 40; ++k) {
        longest = std::max(longest, io.run());
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    EXPECT_LT(longest, std::chrono::milliseconds(3 * timeout_ms));
    // --fail-for: it answers again, and the dispatcher reconnects.
    ASSERT_TRUE(cyclesUntil(run, [] { return IO_STATUS.comm_lost[0] == 0; }));
    EXPECT_NE(static_cast<uint16_t>(AXIS_IN[0].error), 65535);
}

}  // namespace

TEST(IoDispatModbus, SilentDeviceIsCommLostInTheCycleOfItsFirstTimeout) { silentDevice(1); }

TEST(IoDispatModbus, SilentDeviceIsCommLostInTheCycleOfItsThirdTimeoutInARow) { silentDevice(3); }

// A device that stalls for two rounds and then answers: the answer to the request that timed out
// is read back first and dropped, the stalled round sends nothing new, and the first round after
// the stall succeeds.  Sending a new request first took the late answer for its own ("Invalid
// data"), and one stall failed three rounds in a row: comm loss (docs/io-load.md).
TEST(IoDispatModbus, ALateAnswerIsReadBackNotTakenForTheNextRequests) {
    resetVariables();
    DriveSim sim({"--quiet"});
    TempDir dir;
    LoadedModule io;
    ASSERT_EQ(io.load(writeFile(dir, "io.xml",
                                driveConfig(sim.port(), R"(timeout_ms="30" fail_limit="3" reconnect_ms="200")"))),
              "");
    auto run = [&] { io.run(); };
    ASSERT_TRUE(cyclesUntil(run, [] { return IO_STATUS.comm_lost[0] == 0 && IO_STATUS.cycles > 2; }));
    for (int k = 0; k < 3; ++k) io.run();
    const uint32_t errors_before = IO_STATUS.errors[0];
    ASSERT_EQ(kill(sim.pid(), SIGSTOP), 0);
    io.run();  // times out: its answer is owed
    io.run();  // the device still silent: this round fails too, and sends nothing
    EXPECT_EQ(IO_STATUS.errors[0] - errors_before, 2u);
    ASSERT_EQ(kill(sim.pid(), SIGCONT), 0);
    for (int k = 0; k < 20; ++k) {
        io.run();
        ASSERT_EQ(IO_STATUS.comm_lost[0], 0) << "round " << k << " after the stall";
    }
    EXPECT_EQ(IO_STATUS.errors[0] - errors_before, 2u) << "every round after the stall succeeds";
}

// safe_outputs() when the drive is busy past one timeout (20 ms): the write is tried again on a
// new connection, and the controlword reaches 0 once the drive answers.  One attempt left the
// drives enabled on a loaded machine (DeviceSide.AStopDrivesTheControlwordsToZero...).
TEST(IoDispatModbus, SafeOutputsAreTriedAgainWhenTheDeviceAnswersLate) {
    resetVariables();
    DriveSim sim({"--quiet"});
    TempDir dir;
    LoadedModule io;
    ASSERT_EQ(io.load(writeFile(dir, "io.xml", driveConfig(sim.port(), R"(timeout_ms="50" fail_limit="3")"))), "");
    AXIS_OUT[0].controlword = 0x0F;
    PLC_ROBOT::PLC_OUT.Step = 77;
    ModbusClient c(sim.port());
    ASSERT_TRUE(cyclesUntil([&] { io.run(); }, [&] { return c.holding(0, 1)[0] == 0x0F; }));
    ASSERT_EQ(kill(sim.pid(), SIGSTOP), 0);
    irp::Status driven = irp::Ok{};
    std::thread watchdog([&] { driven = io.safeOutputs(); });
    std::this_thread::sleep_for(std::chrono::milliseconds(30));  // past the first attempt's 20 ms
    ASSERT_EQ(kill(sim.pid(), SIGCONT), 0);
    watchdog.join();
    ASSERT_TRUE(driven.ok()) << driven.error().message;
    EXPECT_EQ(c.holding(0, 1)[0], 0);       // controlword: safe="0"
    EXPECT_EQ(c.holding(520, 1)[0], 1234);  // PLC_OUT.Step: safe="1234"
}

TEST(IoDispatModbus, TheBudgetCutsAWaitShorterThanTheTimeout) {
    resetVariables();
    DriveSim sim({"--quiet", "--fail-after", "0"});  // connects (the kernel's backlog), never answers
    TempDir dir;
    LoadedModule io;
    ASSERT_EQ(io.load(writeFile(
                  dir, "io.xml",
                  driveConfig(sim.port(), R"(timeout_ms="2000" fail_limit="100")", "", R"( budget_us="20000")"))),
              "");
    std::chrono::nanoseconds longest{0};
    for (int k = 0; k < 5; ++k) longest = std::max(longest, io.run());
    EXPECT_LT(longest, std::chrono::milliseconds(3 * 20));  // never the 2 s timeout
    EXPECT_GE(IO_STATUS.errors[0], 1u);
}

TEST(IoDispatModbus, AnUnreachableDeviceAtStartIsCommLostNotARefusal) {
    resetVariables();
    const int port = testing_support::closedPort();  // nothing listens there
    TempDir dir;
    LoadedModule io;
    const auto t0 = std::chrono::steady_clock::now();
    ASSERT_EQ(io.load(writeFile(dir, "io.xml", driveConfig(port, R"(timeout_ms="50" reconnect_ms="100")"))), "");
    for (int k = 0; k < 30; ++k) {
        io.run();
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    const auto elapsed = std::chrono::steady_clock::now() - t0;
    EXPECT_EQ(IO_STATUS.comm_lost[0], 1);
    EXPECT_GE(IO_STATUS.errors[0], 2u);  // connect attempts, refused: the first cycle's, then after 10, 20, 40,
    // 80 ms, then at most one per reconnect_ms
    EXPECT_LE(IO_STATUS.errors[0], 5 + elapsed / std::chrono::milliseconds(100));
    EXPECT_EQ(static_cast<uint16_t>(AXIS_IN[0].error), 65535);  // the default from the start
}

TEST(IoDispatModbus, StartRefusesAnUnknownPathNamingTheLine) {
    TempDir dir;
    const std::string text = "<ioconfig>\n  <device name=\"d\" type=\"modbus-tcp\" host=\"127.0.0.1\" port=\"1\">\n"
                             "    <input table=\"input\" address=\"0\" path=\"PLC_ROBOT.AXIS_IN[9].position\"/>\n"
                             "  </device>\n</ioconfig>\n";
    LoadedModule io;
    const std::string e = io.load(writeFile(dir, "io.xml", text));
    EXPECT_REFUSED(e, "module 'libiodispat'", "start() failed", "io.xml:3", "AXIS_IN[9].position");
}

TEST(IoDispatModbus, IrpdRefusesTheFdTestHookNamingTheLine) {
    TempDir dir;
    const std::string text =
        "<ioconfig>\n  <device name=\"bus\" type=\"socketcan\" fd=\"3\">\n"
        "    <frame id=\"0x181\" direction=\"in\"><signal start=\"0\" length=\"16\" path=\"PLC_ROBOT.I0\"/></frame>\n"
        "  </device>\n</ioconfig>\n";
    LoadedModule io;
    const std::string e = io.load(writeFile(dir, "io.xml", text));
    EXPECT_REFUSED(e, "initialize() failed", "io.xml:2", "device 'bus'", "fd=\"3\" is a test hook", "interface=");
}

TEST(IoDispatModbus, InitializeRefusesAMissingConfigSayingWhereItLooked) {
    LoadedModule io;
    const std::string e = io.load("no-such-ioconfig.xml", {{"config_dir", "/nonexistent"}});
    EXPECT_REFUSED(e, "initialize() failed", "property 'config'", "/nonexistent/no-such-ioconfig.xml", "config_dir");
    LoadedModule none;
    EXPECT_REFUSED(none.load(""), "property 'config' is required");
}

TEST(IoDispatModbus, ARelativeConfigIsFoundInConfigDir) {
    resetVariables();
    DriveSim sim({"--quiet"});
    TempDir dir;
    writeFile(dir, "io.xml", driveConfig(sim.port(), R"(timeout_ms="200")"));
    LoadedModule io;
    ASSERT_EQ(io.load("io.xml", {{"config_dir", dir.path.string()}}), "");
    ASSERT_TRUE(cyclesUntil([&] { io.run(); }, [] { return IO_STATUS.comm_lost[0] == 0; }));
}

// ---- Modbus RTU over a pseudo-terminal --------------------------------------------------------------

TEST(IoDispatRtu, RoundTripOverAPseudoTerminal) {
    resetVariables();
    int master = -1, slave = -1;
    char name[128];
    ASSERT_EQ(openpty(&master, &slave, name, nullptr, nullptr), 0);
    // A Modbus RTU server (unit 5) on the master side, as a drive on a serial line would answer.
    modbus_t *server = modbus_new_rtu("/dev/null", 115200, 'N', 8, 1);  // the device name is not opened
    modbus_set_slave(server, 5);
    modbus_set_socket(server, master);
    modbus_mapping_t *map = modbus_mapping_new(0, 0, 16, 16);
    map->tab_input_registers[3] = static_cast<uint16_t>(-1234);
    std::atomic<bool> stop{false};
    std::thread serve([&] {
        uint8_t query[MODBUS_RTU_MAX_ADU_LENGTH];
        while (!stop) {
            fd_set r;
            FD_ZERO(&r);
            FD_SET(master, &r);
            timeval tv{0, 10000};
            if (select(master + 1, &r, nullptr, nullptr, &tv) <= 0) continue;
            const int n = modbus_receive(server, query);
            if (n > 0) modbus_reply(server, query, n, map);
        }
    });
    TempDir dir;
    const std::string text =
        std::string("<ioconfig>\n  <device name=\"line\" type=\"modbus-rtu\" device=\"") + name +
        "\" baud=\"115200\" parity=\"N\" unit=\"5\" timeout_ms=\"500\">\n"
        "    <input  table=\"input\"   address=\"3\" type=\"s16\" path=\"PLC_ROBOT.PLC_OUT.Step\" scale=\"0.5\"/>\n"
        "    <output table=\"holding\" address=\"7\" type=\"u16\" path=\"PLC_ROBOT.PLC_IN.Override\" scale=\"0.01\"/>\n"
        "  </device>\n</ioconfig>\n";
    {
        Dispatcher d(parseIoConfig(writeFile(dir, "io.xml", text)));
        d.start();
        PLC_ROBOT::PLC_IN.Override = 0.75;  // raw 75
        for (int k = 0; k < 200 && (map->tab_registers[7] != 75 || PLC_ROBOT::PLC_OUT.Step != -617); ++k) {
            d.cycle();
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        EXPECT_EQ(map->tab_registers[7], 75);
        EXPECT_EQ(PLC_ROBOT::PLC_OUT.Step, -617);
        EXPECT_FALSE(d.device(0).commLost());
        d.stop();
    }
    stop = true;
    serve.join();
    modbus_mapping_free(map);
    modbus_free(server);
    close(master);
    close(slave);
}
