// restart.hpp -- the managed restart (docs/hot-reload.md, "Managed restart"): irpd stops cleanly
// and executes itself again, same pid, on another set; the old image hands the new one a small
// JSON in the environment (INDUROP_RESTART).  A new set that does not start brings the old one
// back (once: the fallback image never restarts again).
//
//   control thread   `restart`: the set checked as `check` does, a RestartPlan handed to the desk,
//                    answered at once;
//   main thread      takes the plan at its next tick and leaves its loop; the clean stop runs
//                    (outputs to safe values first); the plan gets the end of the last period;
//   main()           reexec(): the control socket is gone already, every descriptor but
//                    /dev/cpu_dma_latency's is close-on-exec, execv(/proc/self/exe).
//   the new image    takeRestartPlan() reads and removes INDUROP_RESTART; it starts on the plan's
//                    set, then reports last_restart and the `restart` (or `restart_failed`) event.
#pragma once

#include <indurop/result.hpp>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace irp::events {
class EventLog;
}

namespace irp::daemon {

inline constexpr const char *kRestartVariable = "INDUROP_RESTART";

struct SetRef {
    std::string config;  // module.xml
    std::string set_id;  // "" = none
    std::string layout;  // the --layout it ran with ("" = its own <layout> or layout.json)
};

// What one image hands the next.
struct RestartPlan {
    SetRef target;               // the set asked for
    SetRef origin;               // the set running when it was asked: the fallback
    int64_t requested_ns = 0;    // CLOCK_MONOTONIC when irpd took the request
    int64_t last_period_ns = 0;  // the end of the origin's last period (the main dispatcher's last slot)
    int64_t stop_ns = 0;         // the old image's stop: leaving the loop -> execv
    int64_t expected_downtime_ns = 0;
    int dma_latency_fd = -1;   // /dev/cpu_dma_latency held open across the exec (-1: none)
    bool fallback = false;     // this image runs the origin again because the target did not start
    Error error;               // fallback: why the target did not start (its message and place)
    std::string process_name;  // the old image's /proc/<pid>/comm, given back to the new one (execv
                               // of /proc/self/exe would name it "exe")

    // The set this image starts on.
    const SetRef &starting() const { return fallback ? origin : target; }
    // The plan for the image that runs the origin again.
    RestartPlan fallBack(const Error &why) const;

    nlohmann::ordered_json toJson() const;
    static Result<RestartPlan> fromJson(const std::string &text);
};

// A set as events and logs name it: its id, or its module.xml when it has none.
std::string describeSet(const SetRef &set);

// INDUROP_RESTART, read and removed from the environment (process modules must not inherit it):
// nullopt when irpd was not started by a restart; an Error when the variable is malformed.
Result<std::optional<RestartPlan>> takeRestartPlan();

// Executes irpd again (same pid) on plan.starting(): `argv` as irpd was started, --config replaced,
// --layout the starting set's.  Returns only when it failed.
Error reexec(const std::vector<std::string> &argv, const RestartPlan &plan);

class RestartDesk;

// In the image a restart started, once its first period ran (at first_period_ns): the downtime
// from the plan's last period, `last_restart` on the desk (with this image's start-up), and a
// `restart` event -- or `restart_failed` when this image is the fallback.
void reportRestart(const RestartPlan &plan, int64_t first_period_ns, int64_t startup_ns, RestartDesk &desk,
                   events::EventLog &events);

// What the control thread and the main thread share about restarts.
class RestartDesk {
public:
    // Control thread: a restart to run at the main thread's next tick; one at a time.
    Status request(RestartPlan plan);
    // Main thread: the restart asked for, if any.
    std::optional<RestartPlan> take();

    // This image's start-up (main() -> the first period's due time), and the restart it came from.
    void started(int64_t startup_ns, nlohmann::ordered_json last_restart);
    nlohmann::ordered_json lastRestart() const;
    // The last restart's measured downtime when this image came from one, else this image's
    // start-up plus `stop_estimate_ns`.
    int64_t expectedDowntimeNs(int64_t stop_estimate_ns) const;

private:
    mutable std::mutex mutex_;
    std::optional<RestartPlan> pending_;
    bool taken_ = false;  // once taken, irpd is going away: later requests are refused
    int64_t startup_ns_ = 0;
    nlohmann::ordered_json last_restart_ = nullptr;
};

}  // namespace irp::daemon
