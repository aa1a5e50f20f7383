// test_iodispat_alarms.cpp -- libiodispat.so's alarms (docs/io.md "Alarms", docs/alarms.md) on the
// plc-robot cell's segment, against indurop-drivesim, with an alarm segment of the test's own
// whose source 1 the module raises on: every device's comm-lost alarm and every drive's fault
// declared in initialize(); comm lost raised with the cause and the error count and cleared when
// the device answers again; a device unreachable from the start alarmed only once its first
// reconnect attempt is due; a drive's fault from its statusword with the error code, cleared by a
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

#include <string>
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

TEST(IoDispatAlarms, ADeviceUnreachableFromTheStartIsAlarmedOnceItsFirstReconnectIsDue) {
    resetVariables();
    Alarms alarms;
    TempDir dir;
    LoadedModule io(kSource);
    ASSERT_EQ(
        io.load(writeFile(dir, "ioconfig.xml", demoConfig(1, R"(timeout_ms="50" fail_limit="3" reconnect_ms="2000")"))),
        "");
    io.run();
    EXPECT_EQ(IO_STATUS.comm_lost[0], 1);
    EXPECT_TRUE(alarms.active().empty()) << "a peer starting with irpd has 2 s to answer";
    ASSERT_TRUE(cyclesUntil([&] { io.run(); }, [&] { return alarms.isActive(100); }));
    const std::string detail = alarms.of(100).at(0).text;
    EXPECT_EQ(detail.rfind("device 'drives': Connection refused (", 0), 0u) << detail;
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
