// alarms.cpp -- the I/O dispatcher's alarms (see alarms.hpp).
#include "alarms.hpp"

#include <cstdio>

namespace irp::iodispat {
namespace {

// A name as an alarm text shows it: at most 60 characters (texts are at most 200).
std::string shown(const std::string &name) { return name.size() <= 60 ? name : name.substr(0, 57) + "..."; }

}  // namespace

std::vector<AlarmText> alarmTexts(const IoConfig &config) {
    std::vector<AlarmText> texts;
    for (std::size_t d = 0; d < config.devices.size(); ++d) {
        const DeviceConfig &dev = config.devices[d];
        texts.push_back({kCommLostAlarm + static_cast<uint32_t>(d), Severity::High,
                         "I/O device '" + shown(dev.name) + "' (" + toString(dev.type) + "): communication lost"});
        for (const DriveConfig &drive : dev.drives)
            texts.push_back({kDriveFaultAlarm + static_cast<uint32_t>(drive.index), Severity::High,
                             "drive '" + shown(drive.name) + "' (device '" + shown(dev.name) + "'): fault"});
    }
    return texts;
}

void DeviceAlarms::start(const IoConfig &config, channel::Handle &handle, const VarTable &vars) {
    drives_.clear();
    lost_.assign(config.devices.size(), 0);
    first_ns_.assign(config.devices.size(), 0);
    for (std::size_t d = 0; d < config.devices.size(); ++d) {
        const DeviceConfig &dev = config.devices[d];
        for (const DriveConfig &drive : dev.drives) {
            const std::string where = config.file + ":" + std::to_string(drive.line) + ": <drive>";
            Drive state{&drive, d, vars.resolve(handle, drive.statusword, where), {}, false};
            if (!drive.error_code.empty()) state.error_code = vars.resolve(handle, drive.error_code, where);
            drives_.push_back(std::move(state));
        }
    }
}

void DeviceAlarms::report(channel::Handle &handle, const std::vector<std::unique_ptr<Device>> &devices,
                          int64_t now_ns) noexcept {
    for (std::size_t d = 0; d < devices.size() && d < lost_.size(); ++d) {
        const Device &dev = *devices[d];
        if (first_ns_[d] == 0) first_ns_[d] = now_ns;
        // Its first exchange had its timeout to be answered (a CAN device's frames to arrive).
        const bool had_time =
            dev.rounds() > 0 || now_ns - first_ns_[d] >= static_cast<int64_t>(dev.config().timeout_ms * 1e6);
        const bool lost = dev.commLost() && had_time;
        if (lost == (lost_[d] != 0)) continue;
        lost_[d] = lost;
        if (lost)
            std::snprintf(detail_, sizeof detail_, "device '%s': %s (%u errors)", dev.config().name.c_str(),
                          dev.cause(), dev.errors());
        irp::alarm(kCommLostAlarm + static_cast<uint32_t>(d), lost, detail_, dev.errors());
    }
    for (Drive &drive : drives_) {
        if (devices[drive.device]->commLost()) continue;  // its statusword is stale: the state stands
        double statusword = 0, code = 0;
        if (!readVar(handle, drive.statusword, statusword)) continue;
        const bool fault = (static_cast<uint32_t>(statusword) & kFaultBit) != 0;
        if (fault == drive.fault) continue;
        drive.fault = fault;
        if (drive.error_code.valid()) readVar(handle, drive.error_code, code);
        if (fault)
            std::snprintf(detail_, sizeof detail_, "drive '%s': statusword 0x%04X, error code 0x%04X",
                          drive.config->name.c_str(), static_cast<unsigned>(statusword), static_cast<unsigned>(code));
        irp::alarm(kDriveFaultAlarm + static_cast<uint32_t>(drive.config->index), fault, detail_, code);
    }
}

}  // namespace irp::iodispat
