// main.cpp -- indurop-drivesim: a Modbus TCP server (libmodbus) emulating N CiA 402 servo axes in
// cyclic synchronous position mode, for the hardware-free cell and the I/O tests.
//
// One thread, one loop (after libmodbus's tests/bandwidth-server-many-up.c): select() on the
// listening socket and every client until the next 1 ms tick of CLOCK_MONOTONIC; a ready client's
// request is received and answered from one modbus_mapping_t; at each tick every axis steps
// 1 ms and its feedback is written into the input registers.  The register map is in
// register_map.hpp and docs/io.md.  Like a real drive's fieldbus watchdog, a master that wrote
// nothing for --comm-timeout ms (after its first write) makes every axis quick-stop and fault
// (0x8130); a fault reset (controlword bit 7) recovers it once the master writes again.
#include "axis.hpp"
#include "register_map.hpp"

#include <modbus.h>

#include <arpa/inet.h>
#include <getopt.h>
#include <netinet/in.h>
#include <sched.h>
#include <signal.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

using namespace irp::drivesim;

namespace {

volatile sig_atomic_t g_stop = 0;
void onSignal(int) { g_stop = 1; }

int64_t nowNs() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

struct Options {
    std::string host = "127.0.0.1";
    int port = 15020;
    int axes = 6;
    double counts_per_rad = 100000;
    std::vector<double> max_velocity{6.0};       // rad/s
    std::vector<double> max_acceleration{60.0};  // rad/s^2
    std::vector<double> initial{0.0};            // rad
    double lag_s = 0.004;
    double following_limit = 0.1;  // rad
    double fail_after = -1;        // s, < 0: never
    double fail_for = -1;          // s, < 0: for ever
    double comm_timeout_ms = 100;  // 0: no comm watchdog
    int rt_priority = 0;           // 0: a normal process
    bool quiet = false;
};

const char *kUsage =
    "usage: indurop-drivesim [options]\n"
    "  A Modbus TCP server emulating CiA 402 servo axes in cyclic synchronous position mode (8).\n"
    "  --host ADDR               IPv4 address to listen on (default 127.0.0.1)\n"
    "  --port P                  TCP port (default 15020; 0: any free port, printed at start)\n"
    "  --axes N                  number of axes, 1..32 (default 6)\n"
    "  --counts-per-rad C        position resolution (default 100000)\n"
    "  --max-velocity V[,V..]    rad/s, one value or one per axis (default 6)\n"
    "  --max-acceleration A[,A..] rad/s^2, one value or one per axis (default 60)\n"
    "  --initial P[,P..]         initial positions, rad (default 0)\n"
    "  --lag S                   time constant of the position loop, s (default 0.004)\n"
    "  --following-limit RAD     |target - actual| above this faults the axis, error 0x8611 (default 0.1)\n"
    "  --fail-after S            stop answering after S seconds (comm-loss tests)\n"
    "  --fail-for S              ...and answer again S seconds later (default: never)\n"
    "  --comm-timeout MS         no write from the master for MS ms: every axis quick-stops and faults,\n"
    "                            error 0x8130 (a drive's fieldbus watchdog; default 100, 0: none)\n"
    "  --rt-priority P           run at SCHED_FIFO P (1..99), as a drive answers from a CPU of its own:\n"
    "                            on a loaded machine a normal process answers up to a scheduler tick\n"
    "                            late (docs/io-load.md); not permitted: a warning, a normal process\n"
    "  --quiet                   print only the listening line and errors\n"
    "Prints \"indurop-drivesim: listening on HOST:PORT\" when ready; SIGTERM or SIGINT end it cleanly.\n";

[[noreturn]] void usage(const std::string &why) {
    std::fprintf(stderr, "indurop-drivesim: %s\n%s", why.c_str(), kUsage);
    std::exit(2);
}

double number(const char *option, const char *text) {
    char *end = nullptr;
    errno = 0;
    double v = std::strtod(text, &end);
    if (!*text || *end || errno || !std::isfinite(v)) usage(std::string(option) + ": '" + text + "' is not a number");
    return v;
}

std::vector<double> numbers(const char *option, const char *text) {
    std::vector<double> out;
    std::string s(text);
    std::size_t start = 0;
    while (true) {
        std::size_t comma = s.find(',', start);
        out.push_back(number(option, s.substr(start, comma - start).c_str()));
        if (comma == std::string::npos) break;
        start = comma + 1;
    }
    return out;
}

Options parse(int argc, char **argv) {
    enum {
        kHost = 1,
        kPort,
        kAxes,
        kCpr,
        kVmax,
        kAmax,
        kInitial,
        kLag,
        kFollowing,
        kFailAfter,
        kFailFor,
        kCommTimeout,
        kRtPriority,
        kQuiet,
        kHelp
    };
    static const option longs[] = {{"host", required_argument, nullptr, kHost},
                                   {"port", required_argument, nullptr, kPort},
                                   {"axes", required_argument, nullptr, kAxes},
                                   {"counts-per-rad", required_argument, nullptr, kCpr},
                                   {"max-velocity", required_argument, nullptr, kVmax},
                                   {"max-acceleration", required_argument, nullptr, kAmax},
                                   {"initial", required_argument, nullptr, kInitial},
                                   {"lag", required_argument, nullptr, kLag},
                                   {"following-limit", required_argument, nullptr, kFollowing},
                                   {"fail-after", required_argument, nullptr, kFailAfter},
                                   {"fail-for", required_argument, nullptr, kFailFor},
                                   {"comm-timeout", required_argument, nullptr, kCommTimeout},
                                   {"rt-priority", required_argument, nullptr, kRtPriority},
                                   {"quiet", no_argument, nullptr, kQuiet},
                                   {"help", no_argument, nullptr, kHelp},
                                   {nullptr, 0, nullptr, 0}};
    Options o;
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, "", longs, nullptr)) != -1) {
        const char *name = optind > 0 && optind <= argc ? argv[optind - 1] : "?";
        switch (c) {
        case kHost: o.host = optarg; break;
        case kPort: {
            double p = number("--port", optarg);
            if (p < 0 || p > 65535 || p != std::floor(p)) usage("--port: expected 0..65535");
            o.port = static_cast<int>(p);
            break;
        }
        case kAxes: {
            double n = number("--axes", optarg);
            if (n < 1 || n > regs::kMaxAxes || n != std::floor(n)) usage("--axes: expected 1..32");
            o.axes = static_cast<int>(n);
            break;
        }
        case kCpr:
            o.counts_per_rad = number("--counts-per-rad", optarg);
            if (o.counts_per_rad <= 0) usage("--counts-per-rad: expected a positive number");
            break;
        case kVmax: o.max_velocity = numbers("--max-velocity", optarg); break;
        case kAmax: o.max_acceleration = numbers("--max-acceleration", optarg); break;
        case kInitial: o.initial = numbers("--initial", optarg); break;
        case kLag:
            o.lag_s = number("--lag", optarg);
            if (o.lag_s < 0.001) usage("--lag: expected at least 0.001 s (one simulation step)");
            break;
        case kFollowing:
            o.following_limit = number("--following-limit", optarg);
            if (o.following_limit <= 0) usage("--following-limit: expected a positive number");
            break;
        case kFailAfter: o.fail_after = number("--fail-after", optarg); break;
        case kFailFor: o.fail_for = number("--fail-for", optarg); break;
        case kCommTimeout:
            o.comm_timeout_ms = number("--comm-timeout", optarg);
            if (o.comm_timeout_ms < 0) usage("--comm-timeout: expected 0 (none) or a number of ms");
            break;
        case kRtPriority: {
            double p = number("--rt-priority", optarg);
            if (p < 1 || p > 99 || p != std::floor(p)) usage("--rt-priority: expected 1..99");
            o.rt_priority = static_cast<int>(p);
            break;
        }
        case kQuiet: o.quiet = true; break;
        case kHelp: std::fputs(kUsage, stdout); std::exit(0);
        default: usage(std::string("unknown option or missing value: ") + name);
        }
    }
    if (optind < argc) usage(std::string("unexpected argument '") + argv[optind] + "'");
    in_addr probe{};
    if (inet_pton(AF_INET, o.host.c_str(), &probe) != 1) usage("--host: '" + o.host + "' is not an IPv4 address");
    auto check = [&](const char *option, std::vector<double> &v, bool positive) {
        if (v.size() != 1 && v.size() != static_cast<std::size_t>(o.axes))
            usage(std::string(option) + ": give one value or one per axis (" + std::to_string(o.axes) + ")");
        for (double x : v)
            if (positive && x <= 0) usage(std::string(option) + ": values must be positive");
        v.resize(static_cast<std::size_t>(o.axes), v.back());
    };
    check("--max-velocity", o.max_velocity, true);
    check("--max-acceleration", o.max_acceleration, true);
    check("--initial", o.initial, false);
    return o;
}

void put32(uint16_t *regs, int at, int32_t v) {
    const auto u = static_cast<uint32_t>(v);
    regs[at] = static_cast<uint16_t>(u >> 16);
    regs[at + 1] = static_cast<uint16_t>(u & 0xFFFF);
}

int32_t get32(const uint16_t *regs, int at) {
    return static_cast<int32_t>((static_cast<uint32_t>(regs[at]) << 16) | regs[at + 1]);
}

class Simulator {
public:
    Simulator(const Options &o, modbus_mapping_t *map) : o_(o), map_(map) {
        for (int i = 0; i < o.axes; ++i) {
            const auto k = static_cast<std::size_t>(i);
            AxisParams p;
            p.max_velocity = o.max_velocity[k] * o.counts_per_rad;
            p.max_acceleration = o.max_acceleration[k] * o.counts_per_rad;
            p.lag_s = o.lag_s;
            p.following_limit = o.following_limit * o.counts_per_rad;
            p.initial_position = o.initial[k] * o.counts_per_rad;
            axes_.emplace_back(p);
            last_state_.push_back(axes_.back().state());
            uint16_t *h = map_->tab_registers + regs::kHoldingStride * i;
            put32(h, regs::kTargetPosition, axes_.back().target());
        }
        map_->tab_input_registers[regs::kAxisCount] = static_cast<uint16_t>(o.axes);
        map_->tab_input_registers[regs::kMapVersion] = regs::kMapVersionValue;
        publish();
    }

    // After every answered request: the holding registers (and coils) may have changed.
    void takeCommands() {
        for (int i = 0; i < o_.axes; ++i) {
            const uint16_t *h = map_->tab_registers + regs::kHoldingStride * i;
            Axis &a = axes_[static_cast<std::size_t>(i)];
            a.setControlword(h[regs::kControlword]);
            a.setMode(static_cast<int8_t>(static_cast<int16_t>(h[regs::kModeOfOperation])));
            a.setTarget(get32(h, regs::kTargetPosition));
        }
        if (uint16_t mask = map_->tab_registers[regs::kFaultInjection]) {
            for (int i = 0; i < o_.axes && i < 16; ++i)
                if (mask & (1u << i)) axes_[static_cast<std::size_t>(i)].injectFault(kErrorInjected);
            map_->tab_registers[regs::kFaultInjection] = 0;
        }
        for (int r = 0; r < regs::kLoopbackCount; ++r)
            map_->tab_input_registers[regs::kLoopback + r] = map_->tab_registers[regs::kLoopback + r];
        for (int b = 0; b < regs::kBits; ++b) map_->tab_input_bits[b] = map_->tab_bits[b];
    }

    // The master has been silent too long: each axis quick-stops (brakes at its maximum
    // deceleration in fault reaction) and ends in fault until a fault reset.
    void commTimeout(double silent_ms) {
        for (Axis &a : axes_) a.injectFault(kErrorCommTimeout);
        std::printf("comm timeout: no write for %.1f ms: every axis quick-stops and faults (error 0x8130)\n",
                    silent_ms);
    }

    void step() {
        for (std::size_t i = 0; i < axes_.size(); ++i) {
            axes_[i].step(0.001);
            if (axes_[i].state() != last_state_[i]) {
                if (!o_.quiet)
                    std::printf("axis %zu: %s -> %s%s\n", i, toString(last_state_[i]), toString(axes_[i].state()),
                                axes_[i].errorCode() ? errorText(axes_[i].errorCode()) : "");
                last_state_[i] = axes_[i].state();
            }
        }
        ++sim_ms_;
        publish();
    }

private:
    static const char *errorText(uint16_t code) {
        return code == kErrorFollowing     ? " (error 0x8611: following error)"
               : code == kErrorInjected    ? " (error 0xFF00: injected fault)"
               : code == kErrorCommTimeout ? " (error 0x8130: comm timeout)"
                                           : " (error)";
    }

    void publish() {
        for (int i = 0; i < o_.axes; ++i) {
            const Axis &a = axes_[static_cast<std::size_t>(i)];
            uint16_t *in = map_->tab_input_registers + regs::kInputStride * i;
            in[regs::kStatusword] = a.statusword();
            in[regs::kErrorCode] = a.errorCode();
            in[regs::kModeDisplay] = static_cast<uint16_t>(static_cast<int16_t>(a.modeDisplay()));
            put32(in, regs::kActualPosition, a.position());
            put32(in, regs::kActualVelocity, a.velocity());
            const double fe = std::clamp(std::round(a.followingError()), -32768.0, 32767.0);
            in[regs::kFollowingError] = static_cast<uint16_t>(static_cast<int16_t>(fe));
        }
        put32(map_->tab_input_registers, regs::kSimTimeMs, static_cast<int32_t>(sim_ms_));
    }

    const Options &o_;
    modbus_mapping_t *map_;
    std::vector<Axis> axes_;
    std::vector<State> last_state_;
    uint32_t sim_ms_ = 0;
};

}  // namespace

int main(int argc, char **argv) {
    const Options o = parse(argc, argv);
    setvbuf(stdout, nullptr, _IOLBF, 0);

    struct sigaction sa {};
    sa.sa_handler = onSignal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, nullptr);  // no SA_RESTART: select() returns EINTR
    sigaction(SIGINT, &sa, nullptr);
    signal(SIGPIPE, SIG_IGN);
    if (o.rt_priority > 0) {
        sched_param param{};
        param.sched_priority = o.rt_priority;
        if (sched_setscheduler(0, SCHED_FIFO, &param) != 0)
            std::fprintf(stderr, "indurop-drivesim: --rt-priority %d: %s; running as a normal process\n", o.rt_priority,
                         std::strerror(errno));
    }

    modbus_t *ctx = modbus_new_tcp(o.host.c_str(), o.port);
    if (!ctx) return std::fprintf(stderr, "indurop-drivesim: modbus_new_tcp: %s\n", modbus_strerror(errno)), 1;
    modbus_set_byte_timeout(ctx, 0, 100000);  // a client that sends half a request stalls us 100 ms at most
    modbus_mapping_t *map = modbus_mapping_new(regs::kBits, regs::kBits, regs::kRegisters, regs::kRegisters);
    if (!map) return std::fprintf(stderr, "indurop-drivesim: modbus_mapping_new: %s\n", modbus_strerror(errno)), 1;

    const int server = modbus_tcp_listen(ctx, 16);
    if (server < 0) {
        std::fprintf(stderr, "indurop-drivesim: cannot listen on %s:%d: %s\n", o.host.c_str(), o.port,
                     modbus_strerror(errno));
        modbus_mapping_free(map);
        modbus_free(ctx);
        return 1;
    }
    sockaddr_in bound{};
    socklen_t bound_len = sizeof bound;
    getsockname(server, reinterpret_cast<sockaddr *>(&bound), &bound_len);
    const int port = ntohs(bound.sin_port);

    Simulator sim(o, map);
    std::printf("indurop-drivesim: listening on %s:%d (%d axes, %g counts/rad, CSP)\n", o.host.c_str(), port, o.axes,
                o.counts_per_rad);

    std::vector<int> clients;
    const int64_t start = nowNs();
    int64_t next_tick = start + 1'000'000;
    bool failing = false;
    // The comm watchdog: armed by a request, fired once by silence, re-armed by the next request.
    bool armed = false;
    int64_t last_request = start;
    const auto comm_timeout = static_cast<int64_t>(o.comm_timeout_ms * 1e6);
    // Judged after the ready requests were read: a simulator starved of CPU first takes the
    // writes queued meanwhile, then decides whether the master went silent.
    auto checkSilence = [&] {
        const int64_t t = nowNs();
        if (armed && comm_timeout > 0 && t - last_request > comm_timeout) {
            armed = false;
            sim.commTimeout(static_cast<double>(t - last_request) / 1e6);
        }
    };
    const int header = modbus_get_header_length(ctx);
    uint8_t query[MODBUS_TCP_MAX_ADU_LENGTH];

    while (!g_stop) {
        int64_t now = nowNs();
        for (int n = 0; now >= next_tick && n < 100; ++n) {
            sim.step();
            next_tick += 1'000'000;
        }
        if (now >= next_tick) next_tick = now + 1'000'000;  // more than 100 ms behind: skip, do not race

        const double elapsed = static_cast<double>(now - start) * 1e-9;
        const bool fail_now =
            o.fail_after >= 0 && elapsed >= o.fail_after && !(o.fail_for >= 0 && elapsed >= o.fail_after + o.fail_for);
        if (fail_now != failing) {
            failing = fail_now;
            armed = false;  // a simulated dead drive has no watchdog running
            if (!o.quiet)
                std::printf("%s\n", failing ? "fail-after: no longer answering" : "fail-for: answering again");
        }

        fd_set ready;
        FD_ZERO(&ready);
        int max_fd = -1;
        if (!failing) {
            FD_SET(server, &ready);
            max_fd = server;
            for (int fd : clients) {
                FD_SET(fd, &ready);
                if (fd > max_fd) max_fd = fd;
            }
        }
        const int64_t wait = std::max<int64_t>(0, next_tick - now);
        timeval tv{static_cast<time_t>(wait / 1'000'000'000), static_cast<suseconds_t>((wait % 1'000'000'000) / 1000)};
        const int rc = select(max_fd + 1, &ready, nullptr, nullptr, &tv);
        if (rc < 0) {
            if (errno == EINTR) continue;
            std::fprintf(stderr, "indurop-drivesim: select: %s\n", std::strerror(errno));
            break;
        }
        if (rc == 0 || failing) {
            checkSilence();
            continue;
        }

        if (FD_ISSET(server, &ready)) {
            sockaddr_in peer{};
            socklen_t len = sizeof peer;
            const int fd = accept(server, reinterpret_cast<sockaddr *>(&peer), &len);
            if (fd >= 0) {
                if (fd >= FD_SETSIZE) {
                    close(fd);  // select() cannot watch it
                } else {
                    clients.push_back(fd);
                    if (!o.quiet)
                        std::printf("client %d connected from %s:%d\n", fd, inet_ntoa(peer.sin_addr),
                                    ntohs(peer.sin_port));
                }
            }
        }
        for (std::size_t k = 0; k < clients.size();) {
            const int fd = clients[k];
            if (!FD_ISSET(fd, &ready)) {
                ++k;
                continue;
            }
            modbus_set_socket(ctx, fd);
            const int n = modbus_receive(ctx, query);
            if (n > 0) {
                modbus_reply(ctx, query, n, map);
                sim.takeCommands();
                // The watchdog is fed by the master's writes (its cyclic outputs), not by readers.
                const uint8_t function = query[header];
                if (function == 0x05 || function == 0x06 || function == 0x0F || function == 0x10 || function == 0x17) {
                    armed = true;
                    last_request = nowNs();
                }
                ++k;
            } else if (n == 0) {
                ++k;  // ignored (not for us)
            } else {
                if (!o.quiet) std::printf("client %d disconnected\n", fd);
                close(fd);
                clients.erase(clients.begin() + static_cast<std::ptrdiff_t>(k));
            }
        }
        checkSilence();
    }

    for (int fd : clients) close(fd);
    close(server);
    modbus_set_socket(ctx, -1);
    modbus_mapping_free(map);
    modbus_free(ctx);
    if (!o.quiet) std::printf("indurop-drivesim: stopped\n");
    return 0;
}
