// test_iodispat.cpp -- the I/O dispatcher against real peers, with a real shared-variable segment
// of the plc-robot cell (cell.glb):
//   - ioconfig.xml: the demo file parses; one named test per malformed input;
//   - encodings: registers (16/32 bit, word order, signed, float), CAN bit fields;
//   - paths: layout form, "::" form, without namespace; structs and unknown paths refused;
//   - Modbus TCP against indurop-drivesim, libiodispat.so loaded through irpd's loader: the demo
//     config round trip for six axes (CiA 402 to operation enabled, targets and positions in rad),
//     every encoding through the simulator's loopback registers, comm loss when the simulator
//     dies (flag in the same cycle, inputs to their defaults, run() bounded, safe outputs written
//     first when it answers again), a silent simulator (--fail-after) against fail_limit, the budget;
//   - Modbus RTU over a pseudo-terminal;
//   - CAN over a socketpair carrying struct can_frame: framing, the signal map, CiA 402 PDOs
//     against the simulator's axis model, comm loss by a missing TPDO; and SocketCAN on vcan0
//     where the kernel has it (skipped with the reason where not).
#include "axis.hpp"
#include "can_device.hpp"
#include "can_port.hpp"
#include "codec.hpp"
#include "dispatcher.hpp"
#include "modbus_device.hpp"
#include "ioconfig.hpp"
#include "register_map.hpp"
#include "variables.hpp"

#include "hosts/thread_module.hpp"
#include "support/drivesim.hpp"
#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"

#include <indurop/generated.h>  // the plc-robot cell's variables (PLC_ROBOT::...)
#include <indurop/indurop.h>

#include <gtest/gtest.h>

#include <net/if.h>
#include <pty.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <bit>
#include <cmath>
#include <fstream>
#include <regex>
#include <thread>

using namespace irp;
using namespace irp::iodispat;
using testing_support::DriveSim;
using testing_support::eventually;
using testing_support::ModbusClient;
using testing_support::TempDir;

namespace {

// ---- one segment for the suite, as irpd makes it before loading modules -----------------------
class Segment : public ::testing::Environment {
public:
    void SetUp() override {
        auto layout = variables::readLayout(std::string(BUILD_ROOT) + "/sets/plc-robot/layout.json");
        ASSERT_TRUE(layout.ok()) << layout.error().message;
        auto segment = variables::VariableSegment::create("test-io-" + std::to_string(getpid()), *layout);
        ASSERT_TRUE(segment.ok()) << segment.error().message;
        segment_ = std::make_unique<variables::VariableSegment>(std::move(*segment));
    }
    void TearDown() override { segment_.reset(); }
    static std::unique_ptr<variables::VariableSegment> segment_;
};
std::unique_ptr<variables::VariableSegment> Segment::segment_;
const auto *const kEnvironment = ::testing::AddGlobalTestEnvironment(new Segment);

using PLC_ROBOT::AXIS_IN;
using PLC_ROBOT::AXIS_OUT;
using PLC_ROBOT::IO_STATUS;

constexpr double kCpr = 100000;  // the simulator's default counts per rad; the demo scales by 1e-5

std::string readText(const std::string &path) {
    std::ifstream in(path);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

std::string writeFile(const TempDir &dir, const std::string &name, const std::string &text) {
    const std::string path = (dir.path / name).string();
    std::ofstream(path) << text;
    return path;
}

void resetVariables() {
    for (int i = 0; i < 6; ++i) {
        AXIS_IN[i] = PLC_ROBOT::AXIS_IN_t{};
        AXIS_OUT[i] = PLC_ROBOT::AXIS_OUT_t{};
    }
    IO_STATUS = PLC_ROBOT::IO_STATUS_t{};
}

// The shipped demo ioconfig.xml with another port and device settings.
std::string demoConfig(int port,
                       const std::string &device_settings = R"(timeout_ms="2" fail_limit="3" reconnect_ms="500")") {
    std::string text = readText(std::string(SOURCE_ROOT) + "/config/sets/plc-robot/ioconfig.xml");
    auto replace = [&](const std::string &from, const std::string &to) {
        const auto at = text.find(from);
        EXPECT_NE(at, std::string::npos) << from;
        if (at != std::string::npos) text.replace(at, from.size(), to);
    };
    replace(R"(port="15020")", "port=\"" + std::to_string(port) + "\"");
    replace(R"(timeout_ms="4" fail_limit="3" reconnect_ms="500")", device_settings);
    return text;
}

// libiodispat.so through irpd's own loader, initialized and started; stopped at the end.
class LoadedModule {
public:
    // "" when it runs, else the loader's or the module's message.
    std::string load(const std::string &config, std::vector<std::pair<std::string, std::string>> more = {}) {
        config::ModuleSpec spec;
        spec.name = "libiodispat";
        spec.filename = "./libiodispat.so";
        spec.path = IODISPAT_PATH;
        spec.where = "test/module.xml:3";
        spec.line = 3;
        spec.period_ns = 10'000'000;
        spec.priority = 1;
        spec.properties = {{"config", config}};
        spec.properties.insert(spec.properties.end(), more.begin(), more.end());
        auto m = hosts::ThreadModule::load(spec);
        if (!m) return m.error().message;
        module_ = std::move(*m);
        if (Status s = module_->initialize(); !s) return s.error().message;
        if (Status s = module_->start(); !s) return s.error().message;
        run_ = module_->runFunction();
        return "";
    }
    ~LoadedModule() {
        if (module_) (void)module_->stop();
    }
    // One cycle, as the dispatcher calls it; returns how long run() took.
    std::chrono::nanoseconds run() {
        const auto t0 = std::chrono::steady_clock::now();
        run_();
        return std::chrono::steady_clock::now() - t0;
    }

private:
    std::unique_ptr<hosts::ThreadModule> module_;
    void (*run_)() = nullptr;
};

// Runs cycles 10 ms apart until done() holds (true) or max_cycles ran (false).
template <class Run, class Done>
bool cyclesUntil(Run &&run, Done done, int max_cycles = 1000) {
    for (int k = 0; k < max_cycles; ++k) {
        run();
        if (done()) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
}

uint16_t state(uint16_t statusword) { return statusword & 0x6F; }

}  // namespace

// ---- ioconfig.xml ---------------------------------------------------------------------------------

TEST(IoConfig, ParsesTheDemoConfig) {
    const IoConfig c = parseIoConfig(std::string(SOURCE_ROOT) + "/config/sets/plc-robot/ioconfig.xml");
    EXPECT_EQ(c.status, "PLC_ROBOT.IO_STATUS");
    ASSERT_EQ(c.devices.size(), 1u);
    const DeviceConfig &d = c.devices[0];
    EXPECT_EQ(d.type, DeviceType::ModbusTcp);
    EXPECT_EQ(d.host, "127.0.0.1");
    EXPECT_EQ(d.port, 15020);
    EXPECT_EQ(d.timeout_ms, 4);
    EXPECT_EQ(d.fail_limit, 3);
    ASSERT_EQ(d.mappings.size(), 48u);  // 6 axes x (5 inputs + 3 outputs)
    const ModbusMapping &pos = d.mappings[3];
    EXPECT_EQ(pos.path, "PLC_ROBOT.AXIS_IN[0].position");
    EXPECT_EQ(pos.format, Format::S32);
    EXPECT_EQ(pos.scaling.scale, 1e-5);
    const ModbusMapping &cw = d.mappings[5];
    EXPECT_EQ(cw.direction, Direction::Out);
    EXPECT_FALSE(cw.safe.hold);
    EXPECT_EQ(cw.safe.value, 0);
    EXPECT_TRUE(d.mappings[7].safe.hold);
}

namespace {

// The message of the ConfigError a device body (inside a modbus-tcp device unless `device` says
// otherwise) raises, or "(accepted)".
std::string refusal(const std::string &body,
                    const std::string &device = R"(name="d" type="modbus-tcp" host="127.0.0.1")",
                    const std::string &root = "") {
    const std::string text =
        "<ioconfig" + root + ">\n  <device " + device + ">\n" + body + "\n  </device>\n</ioconfig>\n";
    try {
        parseIoConfigText(text, "io.xml");
    } catch (const ConfigError &e) {
        return e.what();
    }
    return "(accepted)";
}

#define EXPECT_REFUSED(message, ...)                                                                                   \
    do {                                                                                                               \
        const std::string m = (message);                                                                               \
        for (const char *part : {__VA_ARGS__}) EXPECT_NE(m.find(part), std::string::npos) << m;                        \
    } while (0)

}  // namespace

TEST(IoConfig, AcceptsEveryKindOfMapping) {
    EXPECT_EQ(refusal(R"(
    <input  table="coil" address="1" path="a"/>
    <input  table="discrete" address="2" path="a" default="0"/>
    <input  table="holding" address="3" type="f32" words="low-first" path="a"/>
    <input  table="input" address="4" type="s16" path="a" scale="0.5" offset="-3" unit="7"/>
    <output table="coil" address="1" path="a" safe="1"/>
    <output table="holding" address="10" type="u32" path="a" safe="hold"/>)"),
              "(accepted)");
    EXPECT_EQ(refusal(R"(
    <frame id="0x181" direction="in"><signal start="0" length="12" type="signed" path="a" default="0"/></frame>
    <frame id="0x1ABCDEF" direction="out" dlc="4"><signal start="0" length="32" type="float" path="a" safe="0"/></frame>
    <cia402 node="3" scale="1e-5" controlword="a" target="b" statusword="c" actual="d"/>)",
                      R"(name="c" type="socketcan" fd="5" sync="true")"),
              "(accepted)");
}

TEST(IoConfig, RefusesMalformedXmlWithItsLine) {
    try {
        parseIoConfigText("<ioconfig>\n<device name='x'\n</ioconfig>", "io.xml");
        FAIL() << "accepted";
    } catch (const ConfigError &e) {
        EXPECT_REFUSED(e.what(), "io.xml:", "not well-formed XML");
    }
}

TEST(IoConfig, RefusesAnotherRootElement) {
    try {
        parseIoConfigText("<root/>", "io.xml");
        FAIL() << "accepted";
    } catch (const ConfigError &e) {
        EXPECT_REFUSED(e.what(), "io.xml:1:", "<ioconfig>");
    }
}

TEST(IoConfig, RefusesAnUnknownAttribute) {
    EXPECT_REFUSED(refusal(R"(    <input table="input" address="0" path="a" sacle="2"/>)"), "io.xml:3:", "<input>",
                   "unknown attribute 'sacle'");
}

TEST(IoConfig, RefusesAMappingWithoutPath) {
    EXPECT_REFUSED(refusal(R"(    <input table="input" address="0"/>)"), "io.xml:3:", "'path' is required");
}

TEST(IoConfig, RefusesAnOutputToAReadOnlyTable) {
    EXPECT_REFUSED(refusal(R"(    <output table="input" address="0" path="a"/>)"), "io.xml:3:", "read-only");
}

TEST(IoConfig, RefusesARegisterTypeOnACoil) {
    EXPECT_REFUSED(refusal(R"(    <input table="coil" address="0" type="s32" path="a"/>)"),
                   "io.xml:3:", "type is bool");
}

TEST(IoConfig, RefusesAnUnknownTable) {
    EXPECT_REFUSED(refusal(R"(    <input table="holdings" address="0" path="a"/>)"),
                   "io.xml:3:", "'holdings' is not one of coil, discrete, holding, input");
}

TEST(IoConfig, RefusesTwoOutputsOnOneRegister) {
    EXPECT_REFUSED(refusal("    <output table=\"holding\" address=\"4\" type=\"s32\" path=\"a\"/>\n"
                           "    <output table=\"holding\" address=\"5\" path=\"b\"/>"),
                   "io.xml:4:", "holding 5 of unit 1 is already written by the output at line 3");
}

TEST(IoConfig, RefusesAZeroScale) {
    EXPECT_REFUSED(refusal(R"(    <input table="input" address="0" path="a" scale="0"/>)"),
                   "io.xml:3:", "'scale' must not be 0");
}

TEST(IoConfig, RefusesASafeValueOnAnInput) {
    EXPECT_REFUSED(refusal(R"(    <input table="input" address="0" path="a" safe="0"/>)"),
                   "io.xml:3:", "'safe' is for outputs");
}

TEST(IoConfig, RefusesAHostName) {
    EXPECT_REFUSED(refusal("", R"(name="d" type="modbus-tcp" host="localhost")"), "io.xml:2:", "not an IPv4 address");
}

TEST(IoConfig, RefusesATimeoutOfZero) {
    EXPECT_REFUSED(refusal("", R"(name="d" type="modbus-tcp" host="127.0.0.1" timeout_ms="0")"),
                   "io.xml:2:", "timeout_ms", "outside");
}

TEST(IoConfig, RefusesAnUnknownDeviceType) {
    EXPECT_REFUSED(refusal("", R"(name="d" type="profinet")"),
                   "io.xml:2:", "'profinet' is not one of modbus-tcp, modbus-rtu, socketcan");
}

TEST(IoConfig, RefusesTwoDevicesOfOneName) {
    try {
        parseIoConfigText("<ioconfig>\n<device name='a' type='socketcan' fd='3'/>\n<device name='a' type='socketcan' "
                          "fd='4'/>\n</ioconfig>",
                          "io.xml");
        FAIL() << "accepted";
    } catch (const ConfigError &e) {
        EXPECT_REFUSED(e.what(), "io.xml:3:", "already defined");
    }
}

TEST(IoConfig, RefusesACanDeviceWithBothInterfaceAndFd) {
    EXPECT_REFUSED(refusal("", R"(name="c" type="socketcan" interface="can0" fd="3")"),
                   "io.xml:2:", "either interface");
}

TEST(IoConfig, RefusesALongStandardId) {
    EXPECT_REFUSED(
        refusal(R"(    <frame id="0x800" direction="in" extended="false"/>)", R"(name="c" type="socketcan" fd="3")"),
        "io.xml:3:", "at most 0x7FF");
}

TEST(IoConfig, RefusesASignalPastTheDlc) {
    EXPECT_REFUSED(
        refusal(R"(    <frame id="0x201" direction="out" dlc="2"><signal start="8" length="16" path="a"/></frame>)",
                R"(name="c" type="socketcan" fd="3")"),
        "io.xml:3:", "<signal>", "past the frame's dlc");
}

TEST(IoConfig, RefusesOverlappingOutputSignals) {
    EXPECT_REFUSED(
        refusal(
            R"(    <frame id="0x201" direction="out"><signal start="0" length="16" path="a"/><signal start="8" length="8" path="b"/></frame>)",
            R"(name="c" type="socketcan" fd="3")"),
        "overlaps");
}

TEST(IoConfig, RefusesAFrameIdThatACia402NodeUses) {
    EXPECT_REFUSED(refusal("    <frame id=\"0x181\" direction=\"in\"/>\n    <cia402 node=\"1\" statusword=\"a\"/>",
                           R"(name="c" type="socketcan" fd="3")"),
                   "io.xml:4:", "TPDO1", "0x181", "already used at line 3");
}

TEST(IoConfig, RefusesAModbusElementInACanDevice) {
    EXPECT_REFUSED(refusal(R"(    <input table="input" address="0" path="a"/>)", R"(name="c" type="socketcan" fd="3")"),
                   "io.xml:3:", "<frame> and <cia402>");
}

TEST(IoConfig, NamesAMissingFile) {
    try {
        parseIoConfig("/nonexistent/ioconfig.xml");
        FAIL() << "accepted";
    } catch (const ConfigError &e) {
        EXPECT_REFUSED(e.what(), "/nonexistent/ioconfig.xml", "cannot be read");
    }
}

// ---- encodings ------------------------------------------------------------------------------------

TEST(Codec, RegistersInEveryFormatAndWordOrder) {
    uint16_t r[2];
    encodeRegisters(-2, Format::S16, WordOrder::HighFirst, r);
    EXPECT_EQ(r[0], 0xFFFE);
    EXPECT_EQ(decodeRegisters(r, Format::S16, WordOrder::HighFirst), -2);
    EXPECT_EQ(decodeRegisters(r, Format::U16, WordOrder::HighFirst), 65534);
    encodeRegisters(-100000, Format::S32, WordOrder::HighFirst, r);
    EXPECT_EQ(r[0], 0xFFFE);
    EXPECT_EQ(r[1], 0x7960);
    EXPECT_EQ(decodeRegisters(r, Format::S32, WordOrder::HighFirst), -100000);
    encodeRegisters(0x12345678, Format::U32, WordOrder::LowFirst, r);
    EXPECT_EQ(r[0], 0x5678);
    EXPECT_EQ(r[1], 0x1234);
    EXPECT_EQ(decodeRegisters(r, Format::U32, WordOrder::LowFirst), 0x12345678);
    encodeRegisters(1.5, Format::F32, WordOrder::HighFirst, r);
    EXPECT_EQ(r[0], 0x3FC0);  // 1.5f = 0x3FC00000
    EXPECT_EQ(r[1], 0x0000);
    EXPECT_EQ(decodeRegisters(r, Format::F32, WordOrder::HighFirst), 1.5);
}

TEST(Codec, RegistersRoundAndClamp) {
    uint16_t r[2];
    encodeRegisters(2.6, Format::U16, WordOrder::HighFirst, r);
    EXPECT_EQ(r[0], 3);
    encodeRegisters(-5, Format::U16, WordOrder::HighFirst, r);
    EXPECT_EQ(r[0], 0);
    encodeRegisters(1e9, Format::S16, WordOrder::HighFirst, r);
    EXPECT_EQ(static_cast<int16_t>(r[0]), 32767);
    encodeRegisters(std::nan(""), Format::S32, WordOrder::HighFirst, r);
    EXPECT_EQ(decodeRegisters(r, Format::S32, WordOrder::HighFirst), 0);
    EXPECT_NEAR(toRaw(toVariable(1234, Scaling{1e-5, 0.25}), Scaling{1e-5, 0.25}), 1234, 1e-6);
}

TEST(Codec, CanSignalsAreLittleEndianBitFields) {
    uint8_t d[8] = {};
    insertBits(d, 4, 12, 0xABC);  // straddles bytes 0 and 1
    EXPECT_EQ(d[0], 0xC0);
    EXPECT_EQ(d[1], 0xAB);
    EXPECT_EQ(extractBits(d, 4, 12), 0xABCu);
    CanSignal s;
    s.start = 16;
    s.length = 16;
    s.is_signed = true;
    encodeSignal(d, s, -300);
    EXPECT_EQ(d[2], 0xD4);
    EXPECT_EQ(d[3], 0xFE);
    EXPECT_EQ(decodeSignal(d, s), -300);
    EXPECT_EQ(d[0], 0xC0);  // the neighbour untouched
    s.start = 32;
    s.length = 32;
    s.is_signed = false;
    s.is_float = true;
    encodeSignal(d, s, -2.5);
    EXPECT_EQ(decodeSignal(d, s), -2.5);
    CanSignal small;
    small.start = 60;
    small.length = 4;
    small.is_signed = true;
    encodeSignal(d, small, -9);  // clamped to -8
    EXPECT_EQ(decodeSignal(d, small), -8);
    CanSignal wide;
    wide.start = 0;
    wide.length = 64;
    uint8_t e[8] = {};
    encodeSignal(e, wide, 1e30);  // clamped, not undefined behaviour
    EXPECT_GT(decodeSignal(e, wide), 1.8e19);
}

// ---- paths ----------------------------------------------------------------------------------------

TEST(Paths, ResolveInEveryWrittenForm) {
    channel::Handle h;
    VarTable vars;
    const VarRef a = vars.resolve(h, "PLC_ROBOT.AXIS_IN[2].position", "x");
    EXPECT_EQ(a.path, "PLC_ROBOT.AXIS_IN[2].position");
    EXPECT_EQ(a.kind, ScalarKind::Float);
    EXPECT_EQ(a.size, 8);
    EXPECT_EQ(vars.resolve(h, "PLC_ROBOT::AXIS_IN[2].position", "x").path, a.path);
    EXPECT_EQ(vars.resolve(h, "AXIS_IN[2].position", "x").path, a.path);
    const VarRef s = vars.resolve(h, "AXIS_IN[0].statusword", "x");
    EXPECT_EQ(s.kind, ScalarKind::Unsigned);
    EXPECT_EQ(s.size, 2);
    const VarRef m = vars.resolve(h, "AXIS_OUT[5].mode", "x");
    EXPECT_EQ(m.kind, ScalarKind::Signed);
    EXPECT_EQ(m.size, 1);
    // Values convert to the variable's type: rounded, clamped.
    ASSERT_TRUE(writeVar(h, m, 300.0));
    EXPECT_EQ(static_cast<int8_t>(AXIS_OUT[5].mode), 127);
    ASSERT_TRUE(writeVar(h, s, 2.5e0));
    EXPECT_EQ(static_cast<uint16_t>(AXIS_IN[0].statusword), 3);  // 2.5 rounds away from zero
    double back = 0;
    ASSERT_TRUE(readVar(h, s, back));
    EXPECT_EQ(back, 3);
}

TEST(Paths, RefuseStructsAndUnknownNames) {
    channel::Handle h;
    VarTable vars;
    try {
        vars.resolve(h, "PLC_ROBOT.AXIS_IN[2]", "io.xml:7");
        FAIL() << "accepted";
    } catch (const std::runtime_error &e) {
        EXPECT_REFUSED(e.what(), "io.xml:7:", "is a struct or an array", "e.g. 'PLC_ROBOT.AXIS_IN[2].error'");
    }
    try {
        vars.resolve(h, "AXIS_IN[9].position", "io.xml:8");
        FAIL() << "accepted";
    } catch (const std::runtime_error &e) {
        EXPECT_REFUSED(e.what(), "io.xml:8:", "no scalar shared variable has the path 'AXIS_IN[9].position'");
    }
}

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
    int port;
    {
        DriveSim probe({"--quiet"});
        port = probe.port();
    }  // nothing listens there any more
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
    EXPECT_GE(IO_STATUS.errors[0], 2u);                                            // connect attempts, refused ...
    EXPECT_LE(IO_STATUS.errors[0], 1 + elapsed / std::chrono::milliseconds(100));  // ... at most one per reconnect_ms
    EXPECT_EQ(static_cast<uint16_t>(AXIS_IN[0].error), 65535);                     // the default from the start
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

// ---- CAN over a socketpair ---------------------------------------------------------------------------

namespace {

struct Pair {
    int ours = -1, peer = -1;  // ours: the dispatcher's end
    Pair() {
        int fds[2];
        if (socketpair(AF_UNIX, SOCK_SEQPACKET, 0, fds) == 0) ours = fds[0], peer = fds[1];
    }
    ~Pair() {
        if (ours >= 0) close(ours);
        if (peer >= 0) close(peer);
    }
};

can_frame frame(canid_t id, std::initializer_list<uint8_t> data) {
    can_frame f{};
    f.can_id = id;
    f.can_dlc = static_cast<uint8_t>(data.size());
    std::copy(data.begin(), data.end(), f.data);
    return f;
}

// Every frame waiting at `fd`.
std::vector<can_frame> drain(int fd) {
    std::vector<can_frame> out;
    can_frame f;
    while (recv(fd, &f, sizeof f, MSG_DONTWAIT) == static_cast<ssize_t>(sizeof f)) out.push_back(f);
    return out;
}

void sendFrame(int fd, const can_frame &f) { ASSERT_EQ(send(fd, &f, sizeof f, 0), static_cast<ssize_t>(sizeof f)); }

std::string canConfig(int fd, const std::string &body, const std::string &attrs = "") {
    return "<ioconfig status=\"PLC_ROBOT.IO_STATUS\">\n  <device name=\"can\" type=\"socketcan\" fd=\"" +
           std::to_string(fd) + "\"" + attrs + ">\n" + body + "\n  </device>\n</ioconfig>\n";
}

}  // namespace

TEST(CanPort, CarriesWholeFramesOverASocketpair) {
    Pair p;
    ASSERT_GE(p.ours, 0);
    CanPort port(p.ours);
    can_frame f;
    EXPECT_EQ(port.receive(f), 0);  // nothing waiting: no blocking
    sendFrame(p.peer, frame(0x123, {1, 2, 3}));
    ASSERT_EQ(port.receive(f), 1);
    EXPECT_EQ(f.can_id, 0x123u);
    EXPECT_EQ(f.can_dlc, 3);
    EXPECT_EQ(f.data[2], 3);
    ASSERT_EQ(port.send(frame(0x80, {})), 1);
    auto got = drain(p.peer);
    ASSERT_EQ(got.size(), 1u);
    EXPECT_EQ(got[0].can_id, 0x80u);
    const char junk[3] = {1, 2, 3};
    ASSERT_EQ(send(p.peer, junk, sizeof junk, 0), 3);
    EXPECT_EQ(port.receive(f), -EPROTO);  // not a can_frame: refused, the port goes on
    close(p.peer);
    p.peer = -1;
    EXPECT_EQ(port.receive(f), -EPIPE);  // the peer is gone
}

TEST(CanDevice, SignalMapInAndOut) {
    resetVariables();
    Pair p;
    TempDir dir;
    const std::string body = R"(
    <frame id="0x123" direction="in">
      <signal start="4" length="12" path="PLC_ROBOT.PLC_IN.Override" scale="0.001"/>
      <signal start="16" length="16" type="signed" path="PLC_ROBOT.PLC_OUT.Step"/>
      <signal start="32" length="32" type="float" path="PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[3]"/>
    </frame>
    <frame id="0x1ABCDEF" direction="in">
      <signal start="0" length="1" path="PLC_ROBOT.PLC_OUT.Running"/>
    </frame>
    <frame id="0x321" direction="out" dlc="5">
      <signal start="0" length="16" type="signed" path="PLC_ROBOT.ROBOT_MODULE_SERVICE.eOpCode" scale="0.5" safe="0"/>
      <signal start="16" length="24" path="PLC_ROBOT.ROBOT_MODULE_SERVICE.nSeq" safe="hold"/>
    </frame>)";
    Dispatcher d(parseIoConfig(writeFile(dir, "io.xml", canConfig(p.ours, body, R"( timeout_ms="1000")"))));
    d.start();
    uint8_t in[8] = {};
    insertBits(in, 4, 12, 2500);  // 2.5
    insertBits(in, 16, 16, static_cast<uint16_t>(-7));
    insertBits(in, 32, 32, std::bit_cast<uint32_t>(0.125f));
    can_frame f{};
    f.can_id = 0x123;
    f.can_dlc = 8;
    std::copy(in, in + 8, f.data);
    sendFrame(p.peer, f);
    sendFrame(p.peer, frame(0x1ABCDEF | CAN_EFF_FLAG, {1}));
    PLC_ROBOT::ROBOT_MODULE_SERVICE.eOpCode = -3;  // raw -6
    PLC_ROBOT::ROBOT_MODULE_SERVICE.nSeq = 0x123456;
    d.cycle();
    EXPECT_DOUBLE_EQ(PLC_ROBOT::PLC_IN.Override, 2.5);
    EXPECT_EQ(PLC_ROBOT::PLC_OUT.Step, -7);
    EXPECT_EQ(PLC_ROBOT::ROBOT_MODULE_STATE.dCurJoint[3], 0.125);
    EXPECT_EQ(PLC_ROBOT::PLC_OUT.Running, 1);
    EXPECT_EQ(IO_STATUS.comm_lost[0], 0);
    auto out = drain(p.peer);
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(out[0].can_id, 0x321u);
    EXPECT_EQ(out[0].can_dlc, 5);
    EXPECT_EQ(static_cast<int16_t>(extractBits(out[0].data, 0, 16)), -6);
    EXPECT_EQ(extractBits(out[0].data, 16, 24), 0x123456u);
}

TEST(CanDevice, MissingInputFrameIsCommLossWithSafeOutputsInTheSameCycle) {
    resetVariables();
    Pair p;
    TempDir dir;
    const std::string body = R"(
    <frame id="0x181" direction="in"><signal start="0" length="16" path="PLC_ROBOT.AXIS_IN[0].statusword" default="0"/></frame>
    <frame id="0x201" direction="out"><signal start="0" length="16" path="PLC_ROBOT.AXIS_OUT[0].controlword" safe="0"/>
                                      <signal start="16" length="32" type="signed" path="PLC_ROBOT.AXIS_OUT[0].position" scale="1e-5" safe="hold"/></frame>)";
    Dispatcher d(parseIoConfig(writeFile(dir, "io.xml", canConfig(p.ours, body, R"( timeout_ms="100")"))));
    d.start();
    AXIS_OUT[0].controlword = 0x0F;
    AXIS_OUT[0].position = 0.2;
    sendFrame(p.peer, frame(0x181, {0x37, 0x02}));
    d.cycle();
    ASSERT_EQ(IO_STATUS.comm_lost[0], 0);
    EXPECT_EQ(AXIS_IN[0].statusword, 0x0237);
    auto out = drain(p.peer);
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(extractBits(out[0].data, 0, 16), 0x0Fu);
    // The drive falls silent: the first cycle past the timeout has the flag and sends the safe controlword.
    for (int k = 0; k < 100 && IO_STATUS.comm_lost[0] == 0; ++k) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
        d.cycle();
        out = drain(p.peer);
        ASSERT_EQ(out.size(), 1u);
        if (IO_STATUS.comm_lost[0] == 0) {
            EXPECT_EQ(extractBits(out[0].data, 0, 16), 0x0Fu);
        }
    }
    ASSERT_EQ(IO_STATUS.comm_lost[0], 1);
    EXPECT_EQ(extractBits(out[0].data, 0, 16), 0u);                            // safe
    EXPECT_EQ(static_cast<int32_t>(extractBits(out[0].data, 16, 32)), 20000);  // held
    EXPECT_EQ(AXIS_IN[0].statusword, 0);                                       // the default
    // It talks again.
    sendFrame(p.peer, frame(0x181, {0x37, 0x02}));
    d.cycle();
    EXPECT_EQ(IO_STATUS.comm_lost[0], 0);
    out = drain(p.peer);
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(extractBits(out[0].data, 0, 16), 0x0Fu);
}

namespace {

// A CiA 402 drive on the far end of a CAN link: the simulator's axis model, fed by RPDO1, stepped
// 10 x 1 ms per cycle, answering with TPDO1.  Returns the frames it saw.
std::vector<can_frame> driveNode(int fd, drivesim::Axis &axis, int node) {
    std::vector<can_frame> seen = drain(fd);
    for (const can_frame &f : seen)
        if (f.can_id == 0x200u + static_cast<canid_t>(node) && f.can_dlc >= 6) {
            axis.setControlword(static_cast<uint16_t>(extractBits(f.data, 0, 16)));
            axis.setTarget(static_cast<int32_t>(extractBits(f.data, 16, 32)));
        }
    for (int k = 0; k < 10; ++k) axis.step(0.001);
    can_frame t{};
    t.can_id = 0x180u + static_cast<canid_t>(node);
    t.can_dlc = 6;
    insertBits(t.data, 0, 16, axis.statusword());
    insertBits(t.data, 16, 32, static_cast<uint32_t>(axis.position()));
    send(fd, &t, sizeof t, 0);
    return seen;
}

}  // namespace

TEST(CanDevice, Cia402OverPdosBringsADriveToOperationEnabledAndMovesIt) {
    resetVariables();
    Pair p;
    TempDir dir;
    const std::string body = R"(
    <cia402 node="3" scale="1e-5" controlword="PLC_ROBOT.AXIS_OUT[1].controlword" target="PLC_ROBOT.AXIS_OUT[1].position"
            statusword="PLC_ROBOT.AXIS_IN[1].statusword" actual="PLC_ROBOT.AXIS_IN[1].position"/>)";
    Dispatcher d(parseIoConfig(writeFile(dir, "io.xml", canConfig(p.ours, body, R"( timeout_ms="1000" sync="true")"))));
    d.start();
    drivesim::Axis axis;
    axis.setMode(8);  // the mode is not in these PDOs: set on the drive
    // NMT "start remote node 3" went out when the port opened.
    const auto first = drain(p.peer);
    ASSERT_FALSE(first.empty());
    EXPECT_EQ(first[0].can_id, 0x000u);
    EXPECT_EQ(first[0].data[0], 0x01);
    EXPECT_EQ(first[0].data[1], 3);

    auto cycle = [&] {
        d.cycle();
        return driveNode(p.peer, axis, 3);
    };
    auto until = [&](auto done) {
        for (int k = 0; k < 50; ++k) {
            cycle();
            if (done()) return true;
        }
        return false;
    };
    ASSERT_TRUE(until([] { return (AXIS_IN[1].statusword & 0x4F) == 0x40; }));
    AXIS_OUT[1].controlword = 0x06;
    ASSERT_TRUE(until([] { return state(AXIS_IN[1].statusword) == 0x21; }));
    AXIS_OUT[1].controlword = 0x07;
    ASSERT_TRUE(until([] { return state(AXIS_IN[1].statusword) == 0x23; }));
    AXIS_OUT[1].controlword = 0x0F;
    ASSERT_TRUE(until([] { return state(AXIS_IN[1].statusword) == 0x27; }));
    AXIS_OUT[1].position = 0.05;  // 5000 counts, within the following limit
    ASSERT_TRUE(until([] { return std::abs(AXIS_IN[1].position - 0.05) < 1e-4; }));
    EXPECT_EQ(axis.target(), 5000);
    // Each cycle: RPDO1 (6 bytes) then SYNC.
    d.cycle();
    const auto frames = drain(p.peer);
    ASSERT_EQ(frames.size(), 2u);
    EXPECT_EQ(frames[0].can_id, 0x203u);
    EXPECT_EQ(frames[0].can_dlc, 6);
    EXPECT_EQ(frames[1].can_id, 0x080u);
    EXPECT_EQ(frames[1].can_dlc, 0);
    EXPECT_EQ(IO_STATUS.comm_lost[0], 0);
}

// ---- SocketCAN on vcan0, where the kernel has CAN --------------------------------------------------

TEST(CanVcan, SignalMapOverVcan0) {
    const int probe = socket(PF_CAN, SOCK_RAW, CAN_RAW);
    if (probe < 0)
        GTEST_SKIP() << "this kernel has no CAN support: socket(PF_CAN, SOCK_RAW, CAN_RAW) failed: "
                     << std::strerror(errno)
                     << " (the socketpair tests above cover the framing, the signal map and the CiA 402 PDOs)";
    close(probe);
    if (if_nametoindex("vcan0") == 0) {
        if (geteuid() != 0)
            GTEST_SKIP() << "no vcan0 interface, and not root to create it (ip link add dev vcan0 type vcan)";
        if (std::system("ip link add dev vcan0 type vcan 2>/dev/null; ip link set up vcan0 2>/dev/null") != 0 ||
            if_nametoindex("vcan0") == 0)
            GTEST_SKIP()
                << "no vcan0 interface, and `ip link add dev vcan0 type vcan` failed (is the vcan module available?)";
    }
    resetVariables();
    CanPort peer;
    const auto filters = CanPort::filtersFor({canKey(0x321, false)});
    ASSERT_EQ(peer.open("vcan0", filters), 0) << peer.why();
    TempDir dir;
    const std::string text = R"(<ioconfig status="PLC_ROBOT.IO_STATUS">
  <device name="vcan" type="socketcan" interface="vcan0" timeout_ms="1000">
    <frame id="0x123" direction="in"><signal start="0" length="16" type="signed" path="PLC_ROBOT.PLC_OUT.Step"/></frame>
    <frame id="0x321" direction="out" dlc="2"><signal start="0" length="16" path="PLC_ROBOT.PLC_OUT.ErrorID"/></frame>
  </device>
</ioconfig>
)";
    Dispatcher d(parseIoConfig(writeFile(dir, "io.xml", text)));
    d.start();
    PLC_ROBOT::PLC_OUT.ErrorID = 4242;
    ASSERT_EQ(peer.send(frame(0x123, {0x39, 0x30})), 1);  // 12345
    can_frame f{};
    bool got = false;
    for (int k = 0; k < 100 && !(got && PLC_ROBOT::PLC_OUT.Step == 12345); ++k) {
        d.cycle();
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
        while (peer.receive(f) == 1)
            if (f.can_id == 0x321) got = true;
    }
    EXPECT_EQ(PLC_ROBOT::PLC_OUT.Step, 12345);
    ASSERT_TRUE(got);
    EXPECT_EQ(extractBits(f.data, 0, 16), 4242u);
    EXPECT_EQ(IO_STATUS.comm_lost[0], 0);
}
