// systemd_notify.cpp -- sd_notify(3) and sd_watchdog_enabled(3) from libsystemd, and the rule that
// ties a watchdog ping to the dispatchers' progress.
#include "supervise/systemd_notify.hpp"

#include "osal/clock.hpp"

#include <systemd/sd-daemon.h>

#include <algorithm>
#include <cstdlib>
#include <ctime>

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

// A count that changed since the last tick changed at some time after that tick: credited to
// that tick's time, the earliest it may have, so that a late tick (the main thread delayed)
// never vouches for progress older than the window.
void SystemdNotify::observe(const std::vector<uint64_t> &progress, int64_t now_ns) {
    if (progress.size() != seen_.size()) return;
    for (std::size_t i = 0; i < progress.size(); ++i)
        if (progress[i] != seen_[i]) {
            seen_[i] = progress[i];
            changed_ns_[i] = observed_ns_;
        }
    observed_ns_ = now_ns;
}

int SystemdNotify::firstStalled(int64_t now_ns) const {
    for (std::size_t i = 0; i < changed_ns_.size(); ++i)
        if (now_ns - changed_ns_[i] > windows_ns_[i]) return static_cast<int>(i);
    return -1;
}

void SystemdNotify::ping(const std::string &extra, int64_t now_ns) {
    send("WATCHDOG=1" + extra);
    next_ping_ns_ = now_ns + watchdog_ns_ / 2;
}

void SystemdNotify::ready(const std::string &status, const std::vector<uint64_t> &progress,
                          std::vector<int64_t> windows_ns, int64_t now_ns) {
    if (!active_) return;
    seen_ = progress;
    changed_ns_.assign(progress.size(), now_ns);
    observed_ns_ = now_ns;
    windows_ns_ = std::move(windows_ns);
    windows_ns_.resize(progress.size(), 0);
    std::string message = "READY=1\nSTATUS=" + status;
    if (watchdog_ns_) message += "\nWATCHDOG=1";
    if (watchdog_ns_ && restore_at_ready_) message += "\nWATCHDOG_USEC=" + std::to_string(watchdog_ns_ / 1000);
    send(message);
    next_ping_ns_ = now_ns + watchdog_ns_ / 2;
}

void SystemdNotify::setDispatchers(const std::vector<uint64_t> &progress, std::vector<int64_t> windows_ns,
                                   int64_t now_ns) {
    if (!active_) return;
    seen_ = progress;
    changed_ns_.assign(progress.size(), now_ns);
    windows_ns_ = std::move(windows_ns);
    windows_ns_.resize(progress.size(), 0);
}

void SystemdNotify::status(const std::string &status) { send("STATUS=" + status); }

void SystemdNotify::stopping(const std::string &status) { send("STOPPING=1\nSTATUS=" + status); }

void SystemdNotify::restarting(const std::string &status, int64_t allowance_ns) {
    if (!active_) return;
    const int64_t usec = osal::monotonicNow() / 1000;
    std::string message = "RELOADING=1\nMONOTONIC_USEC=" + std::to_string(usec) + "\nSTATUS=" + status +
                          "\nEXTEND_TIMEOUT_USEC=" + std::to_string(allowance_ns / 1000);
    if (watchdog_ns_) message += "\nWATCHDOG=1\nWATCHDOG_USEC=" + std::to_string((watchdog_ns_ + allowance_ns) / 1000);
    send(message);
}

bool SystemdNotify::tick(const std::vector<uint64_t> &progress, int64_t now_ns) {
    if (!active_ || !watchdog_ns_) return false;
    observe(progress, now_ns);
    stalled_ = firstStalled(now_ns);
    if (now_ns < next_ping_ns_ || stalled_ >= 0 || changed_ns_.empty()) return false;
    ping("", now_ns);
    return true;
}

void SystemdNotify::beginLongWork(int64_t allowance_ns) {
    if (!active_ || !watchdog_ns_) return;
    send("WATCHDOG_USEC=" + std::to_string((watchdog_ns_ + allowance_ns) / 1000));
}

void SystemdNotify::endLongWork(const std::function<std::vector<uint64_t>()> &progress,
                                const std::function<int64_t()> &now) {
    if (!active_ || !watchdog_ns_) return;
    // systemd measures the restored interval from the last ping, maybe long ago: ping with it,
    // once every dispatcher has been seen to complete a slot after the work (waiting at most
    // the longest window for that); else restore only, and systemd acts on the stuck one.
    observe(progress(), now());
    const int64_t start = observed_ns_;
    int64_t longest = 0;
    for (int64_t w : windows_ns_) longest = std::max(longest, w);
    const std::string restore = "WATCHDOG_USEC=" + std::to_string(watchdog_ns_ / 1000);
    for (;;) {
        const timespec pause{0, 1'000'000};
        nanosleep(&pause, nullptr);
        observe(progress(), now());
        bool all = true;
        for (int64_t changed : changed_ns_) all = all && changed >= start;
        if (all) return ping("\n" + restore, observed_ns_);
        if (observed_ns_ - start > longest) return (void)send(restore);
    }
}

}  // namespace irp::supervise
