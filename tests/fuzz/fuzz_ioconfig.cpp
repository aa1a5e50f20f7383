// fuzz_ioconfig.cpp -- libFuzzer target: arbitrary bytes as a set's ioconfig.xml, through what the
// I/O dispatcher does with it when its set starts (rtcore/modules/iodispat, docs/io.md):
// parseIoConfigText, then for a file it accepts, every path resolved against the shared variables
// of the plc-robot cell (a real segment of its layout), the Modbus read and write blocks grouped,
// each device opened, two cycles with every device unreachable (comm loss: fallbacks, safe
// outputs) and the stop.
//
// No input reaches the network or waits: before the start every Modbus TCP device is pointed at
// a loopback port that refuses (bound, never listening), every Modbus RTU device at a serial path
// that does not exist, and every SocketCAN device at a socketpair end (the ioconfig's test hook,
// whatever fd or interface the input named).  A refusal is a ConfigError or runtime_error with a
// message; an empty message, any other exception, a sanitizer report or a time-out is a finding.
// seeds: tests/fuzz/corpus/fuzz_ioconfig (the plc-robot cell's ioconfig.xml and one file per
// device type and mapping kind).
#include "dispatcher.hpp"
#include "ioconfig.hpp"

#include "fuzz_segment.hpp"
#include "sdk/runtime.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <string_view>

using namespace irp::iodispat;

namespace {

int refusing_port = 0;  // bound on 127.0.0.1, never listening: connect() is refused at once
int can_ours = -1, can_peer = -1;

[[noreturn]] void finding(const char *what) {
    std::fprintf(stderr, "fuzz_ioconfig: %s\n", what);
    std::abort();
}

void drain(int fd) {
    char buf[64];
    while (recv(fd, buf, sizeof buf, MSG_DONTWAIT) >= 0) {}
}

// Every device pointed at something local that fails or stays silent at once.
void unreachable(IoConfig &config) {
    for (DeviceConfig &d : config.devices) {
        d.host = "127.0.0.1";
        d.port = refusing_port;
        d.serial = "/nonexistent/indurop-fuzz-tty";
        d.fd = d.type == DeviceType::SocketCan ? can_ours : -1;
    }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int *, char ***) {
    fuzz::plcRobotSegment("fuzz-ioconfig");
    const int s = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof addr;
    int fds[2];
    if (s < 0 || bind(s, reinterpret_cast<sockaddr *>(&addr), sizeof addr) != 0 ||
        getsockname(s, reinterpret_cast<sockaddr *>(&addr), &len) != 0 ||
        socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, fds) != 0) {
        std::perror("fuzz_ioconfig: sockets");
        std::exit(2);
    }
    refusing_port = ntohs(addr.sin_port);  // s stays open (and bound) for the whole run
    can_ours = fds[0];
    can_peer = fds[1];
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size > 65536) return -1;
    const std::string_view text(reinterpret_cast<const char *>(data), size);
    IoConfig config;
    try {
        config = parseIoConfigText(text, "fuzz/ioconfig.xml");
    } catch (const ConfigError &e) {
        if (!*e.what()) finding("a ConfigError without a message");
        return 0;
    }
    unreachable(config);
    drain(can_ours);
    drain(can_peer);
    try {
        Dispatcher dispatcher(std::move(config));
        dispatcher.start();
        dispatcher.cycle();
        dispatcher.cycle();
        dispatcher.stop();
    } catch (const std::runtime_error &e) {  // a path the layout does not have, a refused parameter
        if (!*e.what()) finding("a start refusal without a message");
    }
    irp::runtime::drainLog([](std::string_view) {});  // the log lines irpd would print
    return 0;
}
