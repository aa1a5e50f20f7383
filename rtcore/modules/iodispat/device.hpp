// device.hpp -- what the dispatcher asks of every fieldbus device (Modbus TCP/RTU, SocketCAN):
// start (non-RT: resolve the variables, open, first connect), one bounded exchange per cycle
// (RT), stop; and the comm-lost state and error count it reports in IO_STATUS.
#pragma once

#include "ioconfig.hpp"
#include "variables.hpp"

#include <cstdint>
#include <ctime>
#include <limits>

namespace irp::iodispat {

inline int64_t nowNs() noexcept {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

inline constexpr int64_t kNoDeadline = std::numeric_limits<int64_t>::max();

// One run() of the dispatcher.
struct CycleContext {
    channel::Handle *handle = nullptr;
    int64_t start_ns = 0;               // when run() began
    int64_t deadline_ns = kNoDeadline;  // no transaction may wait past this (the budget)
    uint64_t cycle = 0;                 // run() count, for dividers
};

class Device {
public:
    explicit Device(const DeviceConfig &config) : config_(config) {}
    virtual ~Device() = default;
    Device(const Device &) = delete;
    Device &operator=(const Device &) = delete;

    // Non-RT.  Resolves every path (throws std::runtime_error naming ioconfig.xml's line), opens
    // the device and tries to reach it once; an unreachable device starts comm-lost (not an error).
    virtual void start(channel::Handle &handle, const VarTable &vars) = 0;
    // RT.  At most one exchange round, each wait bounded by the device's timeout and the
    // cycle's deadline.  Never throws, never allocates.
    virtual void exchange(CycleContext &ctx) noexcept = 0;
    // Non-RT.  Closes the device.
    virtual void stop() noexcept = 0;

    const DeviceConfig &config() const { return config_; }
    bool commLost() const { return comm_lost_; }
    uint32_t errors() const { return errors_; }
    uint64_t skipped() const { return skipped_; }  // rounds (or parts) left out for the budget
    uint64_t rounds() const { return rounds_; }    // successful rounds
    // Why it is (or was last) comm-lost: a static text ("Connection refused", "an input frame is missing").
    const char *cause() const { return cause_; }

protected:
    const DeviceConfig &config_;
    bool comm_lost_ = true;  // until the first successful exchange
    uint32_t errors_ = 0;
    uint64_t skipped_ = 0;
    uint64_t rounds_ = 0;
    const char *cause_ = "no answer yet";
};

}  // namespace irp::iodispat
