// test_ioconfig.cpp -- the I/O dispatcher's configuration and conversions, without a peer, with a
// real shared-variable segment of the plc-robot cell (cell.glb):
//   - ioconfig.xml: the demo file parses; one named test per malformed input;
//   - encodings: registers (16/32 bit, word order, signed, float), CAN bit fields;
//   - paths: layout form, "::" form, without namespace; structs and unknown paths refused.
// The dispatcher against its peers: test_iodispat.cpp (Modbus), test_iodispat_can.cpp (CAN).
#include "codec.hpp"
#include "ioconfig.hpp"
#include "variables.hpp"

#include "support/iodispat.hpp"

#include <indurop/generated.h>  // the plc-robot cell's variables (PLC_ROBOT::...)
#include <indurop/indurop.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

using namespace irp;
using namespace irp::iodispat;
using PLC_ROBOT::AXIS_IN;
using PLC_ROBOT::AXIS_OUT;

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
                   "io.xml:3:", "<frame>, <cia402> and <drive>");
}

// <drive>: the drives whose faults are alarms (docs/io.md "Alarms").
TEST(IoConfig, DrivesAreNumberedAcrossTheFileAndNamedByDefault) {
    const IoConfig c = parseIoConfig(std::string(SOURCE_ROOT) + "/config/sets/plc-robot/ioconfig.xml");
    ASSERT_EQ(c.devices[0].drives.size(), 6u);
    EXPECT_EQ(c.devices[0].drives[2].name, "axis 2");
    EXPECT_EQ(c.devices[0].drives[2].index, 2);
    EXPECT_EQ(c.devices[0].drives[2].statusword, "PLC_ROBOT.AXIS_IN[2].statusword");
    EXPECT_EQ(c.devices[0].drives[2].error_code, "PLC_ROBOT.AXIS_IN[2].error");
    const IoConfig two = parseIoConfigText(R"(<ioconfig>
  <device name="a" type="modbus-tcp" host="127.0.0.1">
    <input table="input" address="0" path="s"/><drive statusword="s"/>
  </device>
  <device name="c" type="socketcan" fd="3">
    <cia402 node="2" statusword="t"/><drive name="z" statusword="t"/>
  </device>
</ioconfig>)",
                                           "io.xml");
    EXPECT_EQ(two.devices[0].drives[0].name, "drive 0");
    EXPECT_EQ(two.devices[1].drives[0].index, 1);
    EXPECT_EQ(two.devices[1].drives[0].name, "z");
}

TEST(IoConfig, RefusesADriveWhoseStatuswordIsNoInputOfItsDevice) {
    EXPECT_REFUSED(refusal("    <output table=\"holding\" address=\"0\" path=\"s\"/>\n    <drive statusword=\"s\"/>"),
                   "io.xml:4:", "<drive>", "attribute 'statusword'", "'s' is no input of device 'd'");
}

TEST(IoConfig, RefusesADriveWhoseErrorCodeIsNoInputOfItsDevice) {
    EXPECT_REFUSED(
        refusal(
            "    <input table=\"input\" address=\"0\" path=\"s\"/>\n    <drive statusword=\"s\" error_code=\"e\"/>"),
        "io.xml:4:", "attribute 'error_code'", "'e' is no input");
}

TEST(IoConfig, RefusesADriveWithoutStatusword) {
    EXPECT_REFUSED(refusal(R"(    <drive name="x"/>)"), "io.xml:3:", "<drive>", "attribute 'statusword' is required");
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
