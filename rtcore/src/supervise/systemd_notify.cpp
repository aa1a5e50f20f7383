// systemd_notify.cpp -- sd_notify(3) and sd_watchdog_enabled(3) from libsystemd, and the rule that
// ties a watchdog ping to the dispatchers' progress.
#include "supervise/systemd_notify.hpp"

#include <systemd/sd-daemon.h>

#include <cstdlib>

namespace irp::supervise {

SystemdNotify SystemdNotify::fromEnvironment() {
    SystemdNotify n;
    const char *socket = std::getenv("NOTIFY_SOCKET");
    n.active_ = socket && *socket;
    if (!n.active_) return n;
    uint64_t usec = 0;
    if (sd_watchdog_enabled(0, &usec) > 0 && usec > 0) n.watchdog_ns_ = static_cast<int64_t>(usec) * 1000;
    return n;
}

bool SystemdNotify::send(const std::string &message) {
    if (!active_) return false;
    if (sd_notify(0, message.c_str()) > 0) return true;
    ++failures_;
    return false;
}

bool SystemdNotify::progressed(const std::vector<uint64_t> &progress) const {
    if (progress.size() != at_last_ping_.size()) return false;
    for (std::size_t i = 0; i < progress.size(); ++i)
        if (progress[i] <= at_last_ping_[i]) return false;
    return true;
}

void SystemdNotify::ready(const std::string &status, const std::vector<uint64_t> &progress, int64_t now_ns) {
    if (!active_) return;
    std::string message = "READY=1\nSTATUS=" + status;
    if (watchdog_ns_) message += "\nWATCHDOG=1";
    send(message);
    at_last_ping_ = progress;
    next_ping_ns_ = now_ns + watchdog_ns_ / 2;
}

void SystemdNotify::status(const std::string &status) { send("STATUS=" + status); }

void SystemdNotify::stopping(const std::string &status) { send("STOPPING=1\nSTATUS=" + status); }

bool SystemdNotify::tick(const std::vector<uint64_t> &progress, int64_t now_ns) {
    if (!active_ || !watchdog_ns_ || now_ns < next_ping_ns_ || !progressed(progress)) return false;
    send("WATCHDOG=1");
    at_last_ping_ = progress;
    next_ping_ns_ = now_ns + watchdog_ns_ / 2;
    return true;
}

void SystemdNotify::beginLongWork(int64_t allowance_ns) {
    if (!active_ || !watchdog_ns_) return;
    send("WATCHDOG_USEC=" + std::to_string((watchdog_ns_ + allowance_ns) / 1000));
}

void SystemdNotify::endLongWork(const std::vector<uint64_t> &progress, int64_t now_ns) {
    if (!active_ || !watchdog_ns_) return;
    // systemd measures the restored interval from the last ping: ping first, when earned.
    std::string message = "WATCHDOG_USEC=" + std::to_string(watchdog_ns_ / 1000);
    if (progressed(progress)) {
        message = "WATCHDOG=1\n" + message;
        at_last_ping_ = progress;
        next_ping_ns_ = now_ns + watchdog_ns_ / 2;
    }
    send(message);
}

} // namespace irp::supervise
