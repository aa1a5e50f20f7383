// safe_outputs.cpp -- the safe values written over connections of their own (safe_outputs.hpp).
#include "safe_outputs.hpp"

#include "codec.hpp"

#include <modbus.h>

#include <cerrno>
#include <cstdint>

namespace irp::iodispat {
namespace {

// One device: connect, then one write per output mapping with a safe value.
std::string drive(const DeviceConfig &d, double timeout_ms) {
    modbus_t *mb = modbus_new_tcp(d.host.c_str(), d.port);
    if (!mb) return "device '" + d.name + "': libmodbus refused its parameters: " + modbus_strerror(errno);
    const auto us = static_cast<uint32_t>(timeout_ms * 1000);
    modbus_set_response_timeout(mb, us / 1'000'000, us % 1'000'000);
    modbus_set_byte_timeout(mb, us / 1'000'000, us % 1'000'000);
    modbus_set_error_recovery(mb, MODBUS_ERROR_RECOVERY_NONE);
    std::string failure;
    if (modbus_connect(mb) != 0) {
        failure = "device '" + d.name + "': cannot connect to " + d.host + ":" + std::to_string(d.port) + ": " +
                  modbus_strerror(errno);
    } else {
        for (const ModbusMapping &m : d.mappings) {
            if (m.direction != Direction::Out || m.safe.hold) continue;
            modbus_set_slave(mb, m.unit >= 0 ? m.unit : d.unit);
            const double raw = toRaw(m.safe.value, m.scaling);
            int rc;
            if (m.table == Table::Coil) {
                rc = modbus_write_bit(mb, m.address, raw != 0 && raw == raw ? 1 : 0);
            } else {
                uint16_t regs[2] = {0, 0};
                encodeRegisters(raw, m.format, m.words, regs);
                rc = modbus_write_registers(mb, m.address, registerCount(m.format), regs);
            }
            if (rc < 0) {
                failure = "device '" + d.name + "': writing the safe value of " + m.path + " (" + d.name + " line " +
                          std::to_string(m.line) + ") failed: " + modbus_strerror(errno);
                break;
            }
        }
        modbus_close(mb);
    }
    modbus_free(mb);
    return failure;
}

}  // namespace

std::vector<std::string> driveSafeOutputs(const IoConfig &config, double timeout_ms, int attempts) {
    std::vector<std::string> failures;
    for (const DeviceConfig &d : config.devices) {
        if (d.type != DeviceType::ModbusTcp) continue;
        std::string failure;
        for (int attempt = 1; attempt <= attempts; ++attempt) {
            failure = drive(d, timeout_ms);
            if (failure.empty()) break;
        }
        if (!failure.empty())
            failures.push_back(failure + " (" + std::to_string(attempts) + " attempt" + (attempts == 1 ? "" : "s") +
                               ")");
    }
    return failures;
}

}  // namespace irp::iodispat
