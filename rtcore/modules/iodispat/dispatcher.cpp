// dispatcher.cpp -- the devices in order, the budget, IO_STATUS (see dispatcher.hpp).
#include "dispatcher.hpp"

#include "can_device.hpp"
#include "modbus_device.hpp"

#include <indurop/indurop.h>

#include <stdexcept>

namespace irp::iodispat {

Dispatcher::Dispatcher(IoConfig config) : config_(std::move(config)) {
    for (const DeviceConfig &d : config_.devices) {
        if (d.type == DeviceType::SocketCan)
            devices_.push_back(std::make_unique<CanDevice>(d));
        else
            devices_.push_back(std::make_unique<ModbusDevice>(d));
    }
}

Dispatcher::~Dispatcher() { stop(); }

void Dispatcher::resolveStatus(const VarTable &vars) {
    if (config_.status.empty()) return;
    const std::string where = config_.file + ": <ioconfig status=\"" + config_.status + "\">";
    for (std::size_t d = 0; d < devices_.size(); ++d) {
        const std::string i = "[" + std::to_string(d) + "]";
        status_.comm_lost.push_back(vars.resolve(handle_, config_.status + ".comm_lost" + i,
                                                 where + " (device " + std::to_string(d) + " '" +
                                                     devices_[d]->config().name + "' needs comm_lost" + i + ")"));
        status_.errors.push_back(vars.resolve(handle_, config_.status + ".errors" + i,
                                              where + " (device " + std::to_string(d) + " needs errors" + i + ")"));
    }
    status_.cycles = vars.resolve(handle_, config_.status + ".cycles", where);
    status_.last_cycle_us = vars.resolve(handle_, config_.status + ".last_cycle_us", where);
}

void Dispatcher::start() {
    if (channel::connect(handle_) != 0) throw std::runtime_error(config_.file + ": " + channel::lastError(handle_));
    VarTable vars;
    resolveStatus(vars);
    for (auto &d : devices_) d->start(handle_, vars);
    alarms_.start(config_, handle_, vars);
    cycles_ = 0;
    publishStatus();
}

void Dispatcher::cycle() noexcept {
    const int64_t t0 = nowNs();
    CycleContext ctx;
    ctx.handle = &handle_;
    ctx.start_ns = t0;
    ctx.cycle = cycles_;
    int64_t budget = kNoDeadline;
    if (config_.budget_us > 0)
        budget = static_cast<int64_t>(config_.budget_us * 1000);
    else if (irp::cycle().basic_ns > 0)
        budget = irp::cycle().basic_ns / 2;
    ctx.deadline_ns = budget == kNoDeadline ? kNoDeadline : t0 + budget;

    for (auto &d : devices_)
        if (cycles_ % static_cast<uint64_t>(d->config().divider) == 0) d->exchange(ctx);
    alarms_.report(handle_, devices_, nowNs());
    ++cycles_;

    last_ns_ = nowNs() - t0;
    if (last_ns_ > max_ns_) max_ns_ = last_ns_;
    publishStatus();
}

void Dispatcher::publishStatus() noexcept {
    for (std::size_t d = 0; d < status_.comm_lost.size(); ++d) {
        writeVar(handle_, status_.comm_lost[d], devices_[d]->commLost() ? 1 : 0);
        writeVar(handle_, status_.errors[d], devices_[d]->errors());
    }
    if (status_.cycles.valid()) writeVar(handle_, status_.cycles, static_cast<double>(cycles_ & 0xFFFFFFFFu));
    if (status_.last_cycle_us.valid()) writeVar(handle_, status_.last_cycle_us, static_cast<double>(last_ns_ / 1000));
}

void Dispatcher::stop() noexcept {
    for (auto &d : devices_) d->stop();
}

}  // namespace irp::iodispat
