// alarms.hpp -- the I/O dispatcher's alarms (docs/io.md "Alarms", docs/alarms.md): per device
// "comm lost" (alarm 100 + its index in ioconfig.xml), raised with the cause and the error count
// when the device goes comm-lost and cleared when it answers again; per <drive>, "drive fault"
// (alarm 200 + its index among the file's drives) from the CiA 402 statusword's fault bit, with
// the drive's error code as the value.  The texts are declared in initialize()
// (irp::declareAlarm, module.cpp); report() runs in run(), after the devices' exchanges: no
// allocation, a statusword read per drive, an alarm call only when a state changes.
#pragma once

#include "device.hpp"
#include "ioconfig.hpp"
#include "variables.hpp"

#include <indurop/alarms.h>
#include <indurop/indurop.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace irp::iodispat {

inline constexpr uint32_t kCommLostAlarm = 100;    // + the device's index (at most 64 devices)
inline constexpr uint32_t kDriveFaultAlarm = 200;  // + the drive's index (at most 256 drives)
inline constexpr uint16_t kFaultBit = 0x08;        // CiA 402 statusword bit 3

struct AlarmText {
    uint32_t id;
    Severity severity;
    std::string text;
};
// What initialize() declares for `config`: every device's comm-lost alarm, every drive's fault.
std::vector<AlarmText> alarmTexts(const IoConfig &config);

class DeviceAlarms {
public:
    // Non-RT (Dispatcher::start): the drives' paths resolved.
    void start(const IoConfig &config, channel::Handle &handle, const VarTable &vars);
    // RT: raises and clears what changed since the last call.  A device is alarmed while it is
    // comm-lost, from the start on too (a restart's window until the drives answer): only in the
    // first timeout_ms after the first call (the first cycle) does a device that has not answered
    // yet count as still being reached.  A comm-lost device's drives keep their state (their
    // statusword is stale).
    void report(channel::Handle &handle, const std::vector<std::unique_ptr<Device>> &devices, int64_t now_ns) noexcept;

private:
    struct Drive {
        const DriveConfig *config = nullptr;
        std::size_t device = 0;
        VarRef statusword, error_code;
        bool fault = false;
    };
    std::vector<Drive> drives_;
    std::vector<uint8_t> lost_;      // per device: comm lost was raised
    std::vector<int64_t> first_ns_;  // per device: the first call's time (0: not called yet)
    char detail_[INDUROP_ALARM_TEXT_CHARS] = "";
};

}  // namespace irp::iodispat
