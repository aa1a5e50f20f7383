// test_iodispat_alarms.cpp -- libiodispat.so's alarms (docs/io.md "Alarms", docs/alarms.md) on the
// plc-robot cell's segment, against indurop-drivesim, with an alarm segment of the test's own
// whose source 1 the module raises on: every device's comm-lost alarm and every drive's fault
// declared in initialize(); comm lost raised with the cause and the error count and cleared when
// the device answers again; a device unreachable after the start alarmed once its timeout passed
// (not exempt until a reconnect), and reached in the first cycle; a drive's fault from its statusword with the error code, cleared by a
// fault reset.  ioconfig.xml's <drive> and its refusals: test_ioconfig.cpp.
#include "alarms.hpp"

#include "alarms/alarm_segment.hpp"
#include "support/alarm_ring.hpp"
#include "support/drivesim.hpp"
#include "support/iodispat.hpp"
#include "support/iodispat_module.hpp"
#include "support/irpd.hpp"

#include <indurop/generated.h>  // the plc-robot cell's variables (PLC_ROBOT::...)

#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <string>
#include <thread>
#include <vector>

using irp::alarms::AlarmSegment;
using PLC_ROBOT::AXIS_OUT;
using PLC_ROBOT::IO_STATUS;
using testing_support::AlarmRing;
using testing_support::cyclesUntil;
using testing_support::demoConfig;
using testing_support::DriveSim;
using testing_support::LoadedModule;
using testing_support::resetVariables;
using testing_support::TempDir;
using testing_support::writeFile;

namespace {

constexpr uint32_t kSource = 1;

// An alarm segment of this process, adopted, its source 1 the module's.
struct Alarms {
    AlarmSegment segment{std::move(AlarmSegment::create(testing_support::uniqueInstance(), 4).value())};
    Alarms() {
        segment.adopt();
        segment.claim(kSource, "libiodispat", {});
    }
    std::vector<uint32_t> active() const { return segment.view(kSource).active; }
    bool isActive(uint32_t id) const {
        for (uint32_t a : active())
            if (a == id) return true;
        return false;
    }
    // The records of alarm `id`, oldest first.
    std::vector<indurop_alarm_record> of(uint32_t id) const {
        std::vector<indurop_alarm_record> list;
        AlarmRing ring(segment.header());
        for (uint64_t s = 1; s <= segment.header()->head; ++s)
            if (auto r = ring.read(s); r && r->id == id) list.push_back(*r);
        return list;
    }
};

const std::string kDemoDevice = R"(timeout_ms="50" fail_limit="3" reconnect_ms="200")";

// libiodispat started on the demo config for a port nothing listens on, with a reconnect_ms far
// beyond the test's time; the port.
int startUnreachable(LoadedModule &io, TempDir &dir) {
    const int port = testing_support::closedPort();
    EXPECT_EQ(io.load(writeFile(dir, "ioconfig.xml",
                                demoConfig(port, R"(timeout_ms="50" fail_limit="3" reconnect_ms="5000")"))),
              "");
    return port;
}

}  // namespace

TEST(IoDispatAlarms, InitializeDeclaresCommLostPerDeviceAndAFaultPerDrive) {
    resetVariables();
    Alarms alarms;
    TempDir dir;
    LoadedModule io(kSource);
    ASSERT_EQ(io.load(writeFile(dir, "ioconfig.xml", demoConfig(1, kDemoDevice))), "");  // port 1: nobody
    const auto declared = irp::runtime::alarmsOf(io.module().instance());
    ASSERT_EQ(declared.size(), 7u);
    EXPECT_EQ(declared[0].id, irp::iodispat::kCommLostAlarm);
    EXPECT_EQ(declared[0].text, "I/O device 'drives' (modbus-tcp): communication lost");
    EXPECT_EQ(declared[0].severity, irp::Severity::High);
    EXPECT_TRUE(declared[0].from_code);
    for (uint32_t axis = 0; axis < 6; ++axis) {
        EXPECT_EQ(declared[1 + axis].id, irp::iodispat::kDriveFaultAlarm + axis);
        EXPECT_EQ(declared[1 + axis].text, "drive 'axis " + std::to_string(axis) + "' (device 'drives'): fault");
    }
    EXPECT_EQ(alarms.segment.source(kSource).declared[100 / 64] & (uint64_t{1} << (100 % 64)), uint64_t{1} << 36);
}

TEST(IoDispatAlarms, CommLostIsRaisedWithTheCauseAndTheErrorsAndClearedWhenTheDeviceAnswersAgain) {
    resetVariables();
    Alarms alarms;
    auto sim = std::make_unique<DriveSim>(std::vector<std::string>{"--quiet"});
    const int port = sim->port();
    TempDir dir;
    LoadedModule io(kSource);
    ASSERT_EQ(io.load(writeFile(dir, "ioconfig.xml", demoConfig(port, kDemoDevice))), "");
    auto run = [&] { io.run(); };
    ASSERT_TRUE(cyclesUntil(run, [] { return IO_STATUS.comm_lost[0] == 0; }));
    EXPECT_TRUE(alarms.active().empty());  // the drives are fine too (switch on disabled)

    ASSERT_EQ(sim->stop(SIGKILL), -2);
    sim.reset();
    ASSERT_TRUE(cyclesUntil(run, [] { return IO_STATUS.comm_lost[0] == 1; }));
    EXPECT_EQ(alarms.active(), std::vector<uint32_t>{100});
    auto records = alarms.of(100);
    ASSERT_EQ(records.size(), 1u);
    EXPECT_EQ(records[0].action, INDUROP_ALARM_RAISE);
    EXPECT_EQ(records[0].flags, 0);  // declared
    EXPECT_EQ(records[0].value, static_cast<double>(IO_STATUS.errors[0]));
    const std::string detail = records[0].text;
    EXPECT_EQ(detail.rfind("device 'drives': ", 0), 0u) << detail;
    EXPECT_NE(detail.find(" errors)"), std::string::npos) << detail;
    for (int k = 0; k < 30; ++k) io.run();  // reconnect attempts fail: still one record
    EXPECT_EQ(alarms.of(100).size(), 1u);

    DriveSim again({"--quiet"}, port);
    ASSERT_TRUE(cyclesUntil(run, [] { return IO_STATUS.comm_lost[0] == 0; }));
    EXPECT_TRUE(alarms.active().empty());
    records = alarms.of(100);
    ASSERT_EQ(records.size(), 2u);
    EXPECT_EQ(records[1].action, INDUROP_ALARM_CLEAR);
}

// The window after a (re)start: a device that does not answer is alarmed once it had its timeout
// to answer from the first cycle, however long reconnect_ms is, and the alarm clears as soon as
// the device answers.  (irpd starts a set's processes -- here the drives' simulator -- after the
// thread modules' start(), so start()'s own connect attempt is refused: it must not delay the
// first cycle's attempt by reconnect_ms.)
TEST(IoDispatAlarms, ADeviceUnreachableAfterTheStartIsAlarmedOnceItsTimeoutPassedAndClearedWhenItAnswers) {
    resetVariables();
    Alarms alarms;
    TempDir dir;
    LoadedModule io(kSource);
    const int port = startUnreachable(io, dir);
    io.run();
    EXPECT_EQ(IO_STATUS.comm_lost[0], 1);
    std::this_thread::sleep_for(std::chrono::milliseconds(60));  // past its timeout, long before reconnect_ms
    io.run();
    EXPECT_TRUE(alarms.isActive(100)) << "a device that does not answer after the start is alarmed";
    ASSERT_FALSE(alarms.of(100).empty());
    const std::string detail = alarms.of(100).at(0).text;
    EXPECT_EQ(detail.rfind("device 'drives': Connection refused (", 0), 0u) << detail;

    DriveSim late({"--quiet"}, port);  // the drives come up: reached well before reconnect_ms
    ASSERT_TRUE(cyclesUntil([&] { io.run(); }, [] { return IO_STATUS.comm_lost[0] == 0; }, 200));
    EXPECT_TRUE(alarms.active().empty());
    EXPECT_EQ(alarms.of(100).back().action, INDUROP_ALARM_CLEAR);
}

TEST(IoDispatAlarms, ADeviceThatListensOnlyAfterStartIsReachedInTheFirstCycleWithoutAnAlarm) {
    resetVariables();
    Alarms alarms;
    TempDir dir;
    LoadedModule io(kSource);
    const int port = startUnreachable(io, dir);  // start(): refused
    DriveSim sim({"--quiet"}, port);             // as irpd starts the set's processes after the thread modules
    io.run();
    EXPECT_EQ(IO_STATUS.comm_lost[0], 0) << "the first cycle connects; it does not wait for reconnect_ms";
    EXPECT_TRUE(alarms.of(100).empty());
}

TEST(IoDispatAlarms, ADriveFaultIsRaisedFromItsStatuswordWithTheErrorCodeAndClearedByAFaultReset) {
    resetVariables();
    Alarms alarms;
    DriveSim sim({"--quiet", "--comm-timeout", "100"});
    TempDir dir;
    LoadedModule io(kSource);
    ASSERT_EQ(io.load(writeFile(dir, "ioconfig.xml", demoConfig(sim.port(), kDemoDevice))), "");
    auto run = [&] { io.run(); };
    ASSERT_TRUE(cyclesUntil(run, [] { return IO_STATUS.comm_lost[0] == 0 && PLC_ROBOT::AXIS_IN[5].statusword != 0; }));
    // No write for longer than the drives' comm watchdog: every axis faults with 0x8130.
    std::this_thread::sleep_for(std::chrono::milliseconds(400));
    ASSERT_TRUE(cyclesUntil(run, [&] {
        for (uint32_t axis = 0; axis < 6; ++axis)
            if (!alarms.isActive(200 + axis)) return false;
        return true;
    })) << testing_support::readFile(dir.path / "ioconfig.xml");
    EXPECT_FALSE(alarms.isActive(100));
    for (uint32_t axis = 0; axis < 6; ++axis) {
        const auto records = alarms.of(200 + axis);
        ASSERT_EQ(records.size(), 1u) << axis;
        EXPECT_EQ(records[0].value, 0x8130) << axis;
        EXPECT_NE(std::string(records[0].text).find("error code 0x8130"), std::string::npos) << records[0].text;
        EXPECT_EQ(std::string(records[0].text).rfind("drive 'axis " + std::to_string(axis) + "': statusword 0x", 0), 0u)
            << records[0].text;
    }
    // A fault reset (controlword bit 7, rising edge) clears them.
    for (int i = 0; i < 6; ++i) AXIS_OUT[i].controlword = 0;
    for (int k = 0; k < 3; ++k) io.run();
    for (int i = 0; i < 6; ++i) AXIS_OUT[i].controlword = 0x80;
    ASSERT_TRUE(cyclesUntil(run, [&] { return alarms.active().empty(); }));
    for (uint32_t axis = 0; axis < 6; ++axis) EXPECT_EQ(alarms.of(200 + axis).back().action, INDUROP_ALARM_CLEAR);
}
