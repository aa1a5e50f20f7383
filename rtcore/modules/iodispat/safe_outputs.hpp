// safe_outputs.hpp -- drives every device's outputs to their safe values from outside the I/O
// cycle: irpd calls the module's safe_outputs() on a non-RT thread when a fault stops the set,
// possibly while the RT thread is stuck, even inside this module's own cycle (docs/faults.md).
#pragma once

#include "ioconfig.hpp"

#include <string>
#include <vector>

namespace irp::iodispat {

// Writes, over a connection of its own per Modbus TCP device (never the cycle's), every output
// mapping that has a safe value (safe="hold" ones are left as they are); each connect and
// transaction is bounded by `timeout_ms`.  Reads only the configuration, which nothing changes
// after initialize(), so it is safe beside a running or stuck cycle.  Returns one message per
// device it could not drive (empty: all driven).  Modbus RTU and CAN devices are not driven here:
// the serial line or bus belongs to the cycle; they rely on the device's own comm timeout.
std::vector<std::string> driveSafeOutputs(const IoConfig &config, double timeout_ms);

}  // namespace irp::iodispat
