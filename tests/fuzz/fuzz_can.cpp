// fuzz_can.cpp -- libFuzzer target: arbitrary bytes as what a CAN bus delivers to a SocketCAN
// device of the I/O dispatcher (rtcore/modules/iodispat, docs/io.md): the signal map (unsigned,
// signed and float signals, 1 to 64 bits, standard and extended ids, scaling, defaults) and the
// CiA 402 PDOs (TPDO1 in, RPDO1 out, NMT, SYNC).
//
// The device reads a socketpair(AF_UNIX, SOCK_SEQPACKET) end, the ioconfig's test hook for a CAN
// port, so each message is what one read() of a CAN socket returns.  The input is a list of
// records: a byte 0xFF runs one dispatcher cycle; any other byte h is followed by h % 24 bytes
// sent as one message (16 bytes = one struct can_frame; other sizes are what a broken or hostile
// peer might send).  One cycle runs at the end.  seeds: tests/fuzz/corpus/fuzz_can.
#include "dispatcher.hpp"
#include "ioconfig.hpp"

#include "fuzz_segment.hpp"
#include "sdk/runtime.hpp"

#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

using namespace irp::iodispat;

namespace {

int ours = -1, peer = -1;  // the device's end, the bus's end
std::unique_ptr<IoConfig> config;

std::string ioconfigText(int fd) {
    return R"(<ioconfig status="PLC_ROBOT.IO_STATUS">
  <device name="fuzz" type="socketcan" fd=")" +
           std::to_string(fd) + R"(" timeout_ms="60000" fail_limit="2" sync="true">
    <frame id="0x123" direction="in">
      <signal start="0" length="1" path="PLC_ROBOT.PLC_OUT.Running"/>
      <signal start="4" length="12" path="PLC_ROBOT.PLC_IN.Override" scale="0.001" default="0.5"/>
      <signal start="16" length="16" type="signed" path="PLC_ROBOT.PLC_OUT.Step"/>
      <signal start="32" length="32" type="float" path="PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[3]"/>
    </frame>
    <frame id="0x1ABCDEF" direction="in">
      <signal start="0" length="64" type="signed" path="PLC_ROBOT.PLC_OUT.ErrorID" scale="1e-3"/>
      <signal start="0" length="64" path="PLC_ROBOT.PLC_OUT.Cycles"/>
      <signal start="8" length="32" type="float" path="PLC_ROBOT.AXIS_IN[2].mode" scale="1e300"/>
    </frame>
    <frame id="0x7FF" direction="in">
      <signal start="60" length="4" type="signed" path="PLC_ROBOT.I1"/>
      <signal start="0" length="57" path="PLC_ROBOT.ROBOT_MODULE_STATE.dWorldPos[0]" scale="-1e-9" offset="3"/>
    </frame>
    <frame id="0x321" direction="out" dlc="5">
      <signal start="0" length="16" type="signed" path="PLC_ROBOT.ROBOT_MODULE_SERVICE.eOpCode" scale="0.5" safe="0"/>
      <signal start="16" length="24" path="PLC_ROBOT.ROBOT_MODULE_SERVICE.nSeq" safe="hold"/>
    </frame>
    <cia402 node="3" scale="1e-5" controlword="PLC_ROBOT.AXIS_OUT[1].controlword" target="PLC_ROBOT.AXIS_OUT[1].position"
            statusword="PLC_ROBOT.AXIS_IN[1].statusword" actual="PLC_ROBOT.AXIS_IN[1].position"/>
  </device>
</ioconfig>
)";
}

void drain(int fd) {
    char buf[64];
    while (recv(fd, buf, sizeof buf, MSG_DONTWAIT) >= 0) {}
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int *, char ***) {
    fuzz::plcRobotSegment("fuzz-can");
    int fds[2];
    if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, fds) != 0) {
        std::perror("fuzz_can: socketpair");
        std::exit(2);
    }
    ours = fds[0];
    peer = fds[1];
    config = std::make_unique<IoConfig>(parseIoConfigText(ioconfigText(ours), "fuzz-ioconfig.xml"));
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    drain(ours);  // nothing left from the last input
    drain(peer);
    Dispatcher dispatcher(*config);
    dispatcher.start();
    int queued = 0;
    for (size_t i = 0; i < size;) {
        const uint8_t h = data[i++];
        if (h == 0xFF || queued == 200) {  // at most 200 messages per cycle: within the socket's buffer
            dispatcher.cycle();
            drain(peer);
            queued = 0;
            if (h == 0xFF) continue;
        }
        const size_t n = std::min<size_t>(h % 24, size - i);
        if (send(peer, data + i, n, MSG_DONTWAIT | MSG_NOSIGNAL) >= 0) ++queued;
        i += n;
    }
    dispatcher.cycle();
    dispatcher.stop();
    irp::runtime::drainLog([](std::string_view) {});  // the log lines irpd would print
    return 0;
}
