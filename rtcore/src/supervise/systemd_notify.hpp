// systemd_notify.hpp -- irpd as a systemd Type=notify service (sd_notify(3)): READY=1 once the set
// is dispatched, STATUS= lines, STOPPING=1, and a watchdog ping that proves progress of every
// dispatcher thread, not merely that some side thread is alive (docs/supervision.md).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace irp::supervise {

class SystemdNotify {
public:
    // From the environment systemd sets: NOTIFY_SOCKET (without it every call below does
    // nothing), WATCHDOG_USEC and WATCHDOG_PID (sd_watchdog_enabled(3): a watchdog meant for
    // another process is not ours).
    static SystemdNotify fromEnvironment();

    bool active() const { return active_; }
    // The watchdog interval systemd expects pings within (WatchdogSec=), 0 = no watchdog.
    int64_t watchdogNs() const { return watchdog_ns_; }

    // READY=1 with a STATUS= line.  `progress`: each dispatcher's completed-slot count now (the
    // base the first watchdog ping is measured against); the ready message is a ping too.
    void ready(const std::string &status, const std::vector<uint64_t> &progress, int64_t now_ns);
    void status(const std::string &status);
    void stopping(const std::string &status);

    // The main thread's tick.  From half the watchdog interval after the last ping on, pings
    // (WATCHDOG=1) as soon as every dispatcher's completed-slot count has grown since that
    // ping; a dispatcher that stopped making progress therefore stops the pings, and systemd
    // kills irpd one interval after the last one.  True when it pinged.
    bool tick(const std::vector<uint64_t> &progress, int64_t now_ns);

    // Long work on the main thread (a hot reload: loading, starting processes, the swap) must
    // not be taken for a hang: the interval is stretched by `allowance_ns` for its duration
    // (WATCHDOG_USEC=), then restored together with a ping if every dispatcher progressed.
    void beginLongWork(int64_t allowance_ns);
    void endLongWork(const std::vector<uint64_t> &progress, int64_t now_ns);

    // The messages sent so far that failed (a socket gone; for the log).
    uint64_t failures() const { return failures_; }

private:
    bool send(const std::string &message);
    bool progressed(const std::vector<uint64_t> &progress) const;

    bool active_ = false;
    int64_t watchdog_ns_ = 0;
    int64_t next_ping_ns_ = 0;
    std::vector<uint64_t> at_last_ping_;
    uint64_t failures_ = 0;
};

} // namespace irp::supervise
