// dispatcher.hpp -- the I/O dispatcher: the devices of one ioconfig.xml exchanged in file order
// once per cycle within a time budget, then their alarms (comm lost, drive faults: alarms.hpp)
// and IO_STATUS (comm_lost[d], errors[d], cycles, last_cycle_us) written after them.  module.cpp wraps one of these as libiodispat.so; tests may
// drive it directly.
#pragma once

#include "alarms.hpp"
#include "device.hpp"
#include "ioconfig.hpp"
#include "variables.hpp"

#include <memory>
#include <vector>

namespace irp::iodispat {

class Dispatcher {
public:
    explicit Dispatcher(IoConfig config);
    ~Dispatcher();

    // Non-RT: resolves every path against the running layout, opens the devices, tries each once.
    // Throws std::runtime_error naming the file, line and path on any problem.
    void start();
    // RT: one cycle.  Never throws, never allocates.
    void cycle() noexcept;
    // Non-RT.
    void stop() noexcept;

    const IoConfig &config() const { return config_; }
    std::size_t deviceCount() const { return devices_.size(); }
    const Device &device(std::size_t i) const { return *devices_[i]; }
    uint64_t cycles() const { return cycles_; }
    int64_t lastCycleNs() const { return last_ns_; }
    int64_t maxCycleNs() const { return max_ns_; }

private:
    struct Status {
        std::vector<VarRef> comm_lost, errors;
        VarRef cycles, last_cycle_us;
    };
    void resolveStatus(const VarTable &vars);
    void publishStatus() noexcept;

    IoConfig config_;
    channel::Handle handle_;
    std::vector<std::unique_ptr<Device>> devices_;
    DeviceAlarms alarms_;
    Status status_;
    uint64_t cycles_ = 0;
    int64_t last_ns_ = 0, max_ns_ = 0;
};

}  // namespace irp::iodispat
