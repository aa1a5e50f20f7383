// drivesim.hpp -- the drive simulator (indurop-drivesim) as a test peer: started as a subprocess
// on a free port (or a given one), its port read from its "listening on" line, stopped by pid.
// Plus a small libmodbus client to look at its registers independently of the code under test.
#pragma once

#include "subprocess.hpp"

#include <modbus.h>

#include <signal.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace testing_support {

class DriveSim {
public:
    // Starts DRIVESIM_PATH with `args` on `port` (0: any free port) and waits until it listens.
    // Its comm watchdog is off unless `args` give --comm-timeout: a test that pauses between
    // writes must not see its axes fault.
    explicit DriveSim(std::vector<std::string> args = {}, int port = 0) {
        std::vector<std::string> argv{DRIVESIM_PATH, "--port", std::to_string(port), "--comm-timeout", "0"};
        argv.insert(argv.end(), args.begin(), args.end());
        process_ = std::make_unique<Process>(argv, dir_.path);
        const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
        while (std::chrono::steady_clock::now() < end) {
            const std::string out = process_->out();
            const auto at = out.find("listening on ");
            const auto nl = at == std::string::npos ? std::string::npos : out.find('\n', at);
            if (nl != std::string::npos) {
                const auto colon = out.rfind(':', out.find(' ', at + 13));
                port_ = std::stoi(out.substr(colon + 1));
                return;
            }
            if (process_->wait(std::chrono::milliseconds(1)) != -1)
                throw std::runtime_error("indurop-drivesim exited at start: " + process_->err());
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
        throw std::runtime_error("indurop-drivesim did not listen within 20 s: " + process_->err());
    }
    ~DriveSim() { stop(); }

    int port() const { return port_; }
    pid_t pid() const { return process_->pid(); }
    std::string out() const { return process_->out(); }
    std::string err() const { return process_->err(); }

    // Ends it with `signal` (by pid) and returns its exit status (-2: killed by a signal).
    int stop(int signal = SIGTERM) {
        if (stopped_) return status_;
        stopped_ = true;
        kill(process_->pid(), signal);
        status_ = process_->wait(std::chrono::seconds(20));
        if (status_ == -1) {
            kill(process_->pid(), SIGKILL);
            status_ = process_->wait(std::chrono::seconds(20));
        }
        return status_;
    }

private:
    TempDir dir_;
    std::unique_ptr<Process> process_;
    int port_ = 0;
    bool stopped_ = false;
    int status_ = -1;
};

// A loopback port nothing listens on any more: a simulator's, closed (a device unreachable at start,
// or one whose simulator comes up later on that port).
inline int closedPort() { return DriveSim({"--quiet"}).port(); }

// A libmodbus TCP client, connected on construction (throws if it cannot).
class ModbusClient {
public:
    explicit ModbusClient(int port, double timeout_s = 2.0) : ctx_(modbus_new_tcp("127.0.0.1", port)) {
        if (!ctx_) throw std::runtime_error("modbus_new_tcp failed");
        const auto us = static_cast<uint32_t>(timeout_s * 1e6);
        modbus_set_response_timeout(ctx_, us / 1'000'000, us % 1'000'000);
        modbus_set_slave(ctx_, 1);
        if (modbus_connect(ctx_) != 0) {
            const std::string why = modbus_strerror(errno);
            modbus_free(ctx_);
            throw std::runtime_error("cannot connect to the drive simulator on port " + std::to_string(port) + ": " +
                                     why);
        }
    }
    ~ModbusClient() {
        modbus_close(ctx_);
        modbus_free(ctx_);
    }
    ModbusClient(const ModbusClient &) = delete;
    ModbusClient &operator=(const ModbusClient &) = delete;

    modbus_t *ctx() { return ctx_; }

    std::vector<uint16_t> input(int address, int count) {
        std::vector<uint16_t> r(static_cast<std::size_t>(count));
        if (modbus_read_input_registers(ctx_, address, count, r.data()) != count)
            throw std::runtime_error(std::string("read input registers: ") + modbus_strerror(errno));
        return r;
    }
    std::vector<uint16_t> holding(int address, int count) {
        std::vector<uint16_t> r(static_cast<std::size_t>(count));
        if (modbus_read_registers(ctx_, address, count, r.data()) != count)
            throw std::runtime_error(std::string("read holding registers: ") + modbus_strerror(errno));
        return r;
    }
    void write(int address, std::vector<uint16_t> values) {
        if (modbus_write_registers(ctx_, address, static_cast<int>(values.size()), values.data()) !=
            static_cast<int>(values.size()))
            throw std::runtime_error(std::string("write holding registers: ") + modbus_strerror(errno));
    }
    uint16_t input1(int address) { return input(address, 1)[0]; }
    int32_t input32(int address) {
        auto r = input(address, 2);
        return static_cast<int32_t>((uint32_t{r[0]} << 16) | r[1]);
    }
    int32_t holding32(int address) {
        auto r = holding(address, 2);
        return static_cast<int32_t>((uint32_t{r[0]} << 16) | r[1]);
    }
    void write32(int address, int32_t v) {
        const auto u = static_cast<uint32_t>(v);
        write(address, {static_cast<uint16_t>(u >> 16), static_cast<uint16_t>(u & 0xFFFF)});
    }

private:
    modbus_t *ctx_;
};

// Polls `done` every few ms until it holds or `limit` passes (a wait that only ends early).
template <class Fn>
bool eventually(Fn done, std::chrono::milliseconds limit = std::chrono::seconds(10)) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < end) {
        if (done()) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return done();
}

}  // namespace testing_support
