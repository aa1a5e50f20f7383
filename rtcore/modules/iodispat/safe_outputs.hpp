// safe_outputs.hpp -- drives every device's outputs to their safe values from outside the I/O
// cycle: irpd calls the module's safe_outputs() on a non-RT thread when a fault stops the set,
// possibly while the RT thread is stuck, even inside this module's own cycle (docs/faults.md).
#pragma once

#include "ioconfig.hpp"

#include <string>
#include <vector>

namespace irp::iodispat {

// What safe_outputs() uses (docs/io.md, "Safe outputs when a fault stops the set").
constexpr double kSafeTimeoutMs = 20.0;
constexpr int kSafeAttempts = 3;

// Writes, over a connection of its own per Modbus TCP device (never the cycle's), every output
// mapping that has a safe value (safe="hold" ones are left as they are); each connect and
// transaction is bounded by `timeout_ms`, and a device that fails is tried again on a new
// connection, up to `attempts` times in all (a drive busy for one timeout still gets its safe
// values).  Reads only the configuration, which nothing changes
// after initialize(), so it is safe beside a running or stuck cycle.  Returns one message per
// device it could not drive in any attempt (empty: all driven).  Modbus RTU and CAN devices are not driven here:
// the serial line or bus belongs to the cycle; they rely on the device's own comm timeout.
std::vector<std::string> driveSafeOutputs(const IoConfig &config, double timeout_ms, int attempts);

}  // namespace irp::iodispat
