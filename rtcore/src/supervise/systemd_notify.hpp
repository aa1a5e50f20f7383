// systemd_notify.hpp -- irpd as a systemd Type=notify service (sd_notify(3)): READY=1 once the set
// is dispatched, STATUS= lines, STOPPING=1, and a watchdog ping that proves progress of every
// dispatcher thread, not merely that some side thread is alive (docs/supervision.md).
#pragma once

#include <cstdint>
#include <functional>
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

    // READY=1 with a STATUS= line.  `progress`: each dispatcher's completed-slot count now;
    // `windows_ns`: for each, how long it may go without completing a slot and still count as
    // making progress (a little more than its basic period plus the main thread's tick).
    void ready(const std::string &status, const std::vector<uint64_t> &progress, std::vector<int64_t> windows_ns,
               int64_t now_ns);
    // After a hot swap: the dispatchers of the new generation (a swap may add or remove
    // executors and change their basic periods), their progress now and their windows.  Each
    // counts as having moved now: every one of them took its table at the swap.
    void setDispatchers(const std::vector<uint64_t> &progress, std::vector<int64_t> windows_ns, int64_t now_ns);
    void status(const std::string &status);
    void stopping(const std::string &status);
    // A managed restart: the same process executes itself again.  RELOADING=1 (with
    // MONOTONIC_USEC), the STATUS= line, EXTEND_TIMEOUT_USEC= and the watchdog interval stretched
    // by `allowance_ns` with a last ping, so that neither the reload's timeout nor the watchdog
    // ends the restart; the next image's READY=1 ends the reload.
    void restarting(const std::string &status, int64_t allowance_ns);
    // In the image a restart started: READY=1 also restores the configured interval.
    void restoreIntervalAtReady() { restore_at_ready_ = true; }

    // The main thread's tick: notes which dispatchers completed slots since the last tick, and
    // from half the watchdog interval after the last ping on, pings (WATCHDOG=1) when every
    // dispatcher completed a slot within its window.  A dispatcher that stops making progress
    // stops the pings within its window; systemd kills irpd one interval after the last one.
    // True when it pinged.
    bool tick(const std::vector<uint64_t> &progress, int64_t now_ns);

    // Long work on the main thread (a hot reload: loading, starting processes, the swap) must
    // not be taken for a hang: the interval is stretched by `allowance_ns` for its duration
    // (WATCHDOG_USEC=), then restored together with a ping if every dispatcher completes a slot
    // within its window after the work (`progress` is asked again for up to that long).
    void beginLongWork(int64_t allowance_ns);
    void endLongWork(const std::function<std::vector<uint64_t>()> &progress, const std::function<int64_t()> &now);

    // The first dispatcher that completed no slot within its window as of the last tick (the
    // one holding the pings back), -1 when every one did or there is no watchdog.
    int stalled() const { return stalled_; }

    // The messages sent so far that failed (a socket gone; for the log).
    uint64_t failures() const { return failures_; }

private:
    bool send(const std::string &message);
    void observe(const std::vector<uint64_t> &progress, int64_t now_ns);
    // The first dispatcher without a completed slot within its window, -1 when none.
    int firstStalled(int64_t now_ns) const;
    void ping(const std::string &extra, int64_t now_ns);

    bool active_ = false;
    int64_t watchdog_ns_ = 0;
    int64_t next_ping_ns_ = 0;
    std::vector<uint64_t> seen_;       // each dispatcher's count at the last tick
    std::vector<int64_t> changed_ns_;  // the tick before it was last seen to change (the earliest it may have)
    int64_t observed_ns_ = 0;          // the last tick
    std::vector<int64_t> windows_ns_;
    uint64_t failures_ = 0;
    int stalled_ = -1;
    bool restore_at_ready_ = false;
};

}  // namespace irp::supervise
