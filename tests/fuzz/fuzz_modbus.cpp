// fuzz_modbus.cpp -- libFuzzer target: arbitrary bytes as everything a Modbus TCP device answers,
// through the I/O dispatcher's device cycle (rtcore/modules/iodispat, docs/io.md).
//
// Each input: a Dispatcher with a fixed ioconfig (every table, every register format and word
// order, scaling, defaults, safe values, a second unit) connects to a listening socket on
// 127.0.0.1; the peer's side of the connection is given the input as its whole byte stream and
// then shut for writing, and the dispatcher runs three cycles against it.  libmodbus checks the
// frames; what this exercises is our code around it: blocks, exception answers, comm loss,
// fallbacks, safe outputs, decoding and scaling into the shared variables (a real segment of the
// plc-robot layout).  No wait depends on the input: when the bytes run out the device sees the
// connection close.  seeds: tests/fuzz/corpus/fuzz_modbus (tests/fuzz/make_seeds.py).
#include "dispatcher.hpp"
#include "ioconfig.hpp"

#include "fuzz_segment.hpp"
#include "sdk/runtime.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

using namespace irp::iodispat;

namespace {

int listener = -1;
std::unique_ptr<IoConfig> config;

// Inputs in unit 1 (coil 10, discrete 0..5, input registers 0..9), unit 2 (holding 100..101);
// outputs coil 0 and holding 0..2.  One cycle: FC1 coil 0, FC3 holding 0..2 (the outputs read
// once), FC1 coil 10, FC2 discrete 0..5, FC4 input 0..9, FC3 unit 2 holding 100..101, FC15 coil 0,
// FC16 holding 0..2.
std::string ioconfigText(int port) {
    return R"(<ioconfig status="PLC_ROBOT.IO_STATUS">
  <device name="fuzz" type="modbus-tcp" host="127.0.0.1" port=")" +
           std::to_string(port) + R"(" unit="1"
          timeout_ms="1000" fail_limit="2" reconnect_ms="600000">
    <input  table="input"    address="0" type="u16" path="PLC_ROBOT.AXIS_IN[0].statusword"/>
    <input  table="input"    address="1" type="s16" path="PLC_ROBOT.AXIS_IN[0].mode" default="-1"/>
    <input  table="input"    address="2" type="s32" words="low-first" path="PLC_ROBOT.AXIS_IN[0].position" scale="1e-5"/>
    <input  table="input"    address="4" type="f32" path="PLC_ROBOT.AXIS_IN[0].velocity" scale="1e300" offset="-1"/>
    <input  table="input"    address="6" type="f32" words="little" path="PLC_ROBOT.PLC_OUT.Step"/>
    <input  table="input"    address="8" type="u32" path="PLC_ROBOT.PLC_OUT.Cycles" scale="-3"/>
    <input  table="holding"  address="100" unit="2" type="s32" path="PLC_ROBOT.PLC_OUT.ErrorID" scale="1e10"/>
    <input  table="discrete" address="0" path="PLC_ROBOT.PLC_OUT.Running" default="1"/>
    <input  table="discrete" address="5" path="PLC_ROBOT.PLC_OUT.Done"/>
    <input  table="coil"     address="10" path="PLC_ROBOT.PLC_OUT.Powered"/>
    <output table="coil"     address="0" path="PLC_ROBOT.I0" safe="0"/>
    <output table="holding"  address="0" type="u16" path="PLC_ROBOT.AXIS_OUT[0].controlword" safe="0"/>
    <output table="holding"  address="1" type="s32" path="PLC_ROBOT.AXIS_OUT[0].position" scale="1e-5" safe="hold"/>
  </device>
</ioconfig>
)";
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int *, char ***) {
    fuzz::plcRobotSegment("fuzz-modbus");
    listener = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof addr;
    if (listener < 0 || bind(listener, reinterpret_cast<sockaddr *>(&addr), sizeof addr) != 0 ||
        listen(listener, 8) != 0 || getsockname(listener, reinterpret_cast<sockaddr *>(&addr), &len) != 0) {
        std::perror("fuzz_modbus: listening socket");
        std::exit(2);
    }
    config = std::make_unique<IoConfig>(parseIoConfigText(ioconfigText(ntohs(addr.sin_port)), "fuzz-ioconfig.xml"));
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size > 16384) return -1;  // within the socket's buffer: the peer never waits
    Dispatcher dispatcher(*config);
    dispatcher.start();  // connects: the kernel completes it in the listen backlog
    const int peer = accept4(listener, nullptr, nullptr, SOCK_CLOEXEC);
    if (peer < 0) {
        std::perror("fuzz_modbus: accept");
        std::abort();
    }
    for (size_t done = 0; done < size;) {
        const ssize_t n = send(peer, data + done, size - done, MSG_NOSIGNAL);
        if (n <= 0) break;
        done += static_cast<size_t>(n);
    }
    shutdown(peer, SHUT_WR);
    for (int i = 0; i < 3; ++i) dispatcher.cycle();
    dispatcher.stop();
    irp::runtime::drainLog([](std::string_view) {});  // the log lines irpd would print
    close(peer);
    return 0;
}
