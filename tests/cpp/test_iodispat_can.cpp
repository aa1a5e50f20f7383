// test_iodispat_can.cpp -- the I/O dispatcher's CAN devices, with a real shared-variable segment
// of the plc-robot cell (cell.glb): over a socketpair carrying struct can_frame (framing, the
// signal map, CiA 402 PDOs against the simulator's axis model, comm loss by a missing TPDO); and
// SocketCAN on vcan0 where the kernel has it (skipped with the reason where not; ctest also runs
// it in a QEMU guest whose kernel has vcan: CanOnVcanInQemu, tests/vcan/qemu_vcan.sh).
#include "axis.hpp"
#include "can_device.hpp"
#include "can_port.hpp"
#include "codec.hpp"
#include "dispatcher.hpp"
#include "ioconfig.hpp"

#include "support/iodispat.hpp"

#include <indurop/generated.h>  // the plc-robot cell's variables (PLC_ROBOT::...)
#include <indurop/indurop.h>

#include <gtest/gtest.h>

#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <thread>

using namespace irp;
using namespace irp::iodispat;
using PLC_ROBOT::AXIS_IN;
using PLC_ROBOT::AXIS_OUT;
using PLC_ROBOT::IO_STATUS;
using testing_support::resetVariables;
using testing_support::state;
using testing_support::TempDir;
using testing_support::writeFile;

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
