// process_hang_watch.hpp -- a periodic process module with <on_overrun> whose release has not
// completed within its <overrun_limit> hangs (docs/faults.md): warn (an event), restart (SIGKILL;
// the supervisor restarts it per its `restart` property) or stop the set (outputs to safe values).
// Looked at by irpd's main thread every tick; one action per release.
#pragma once

#include "dispatch/watchdog.hpp"
#include "events/event_log.hpp"
#include "hosts/control_segment.hpp"
#include "hosts/process_supervisor.hpp"
#include "reload/generation.hpp"
#include "stats/stats_segment.hpp"

#include <sys/types.h>

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>

namespace irp::watch {

// What acting on a hang takes besides the decision.  irpd's: the supervisor's view of the
// process, kill(2) and the watchdog's stopSet; a test's: fakes.
struct HangActions {
    std::function<std::optional<hosts::ProcessInfo>(const std::string &module)> process;
    std::function<void(pid_t)> kill;                        // SIGKILL to the process
    std::function<void(const dispatch::Fault &)> stop_set;  // halts every executor, drives safe outputs
};

class ProcessHangWatch {
public:
    // Acts on every release in flight longer than its module's limit at `now` (CLOCK_MONOTONIC),
    // once per release: a "process_hang" event, a line on irpd's log, then its action.
    void look(const reload::Generation &g, hosts::ControlSegment &control, events::EventLog &log,
              stats::StatsSegment &stats, const HangActions &act, int64_t now);

private:
    struct Acted {
        uint64_t generation = 0;  // the slot's process generation (a restart is a new one)
        uint32_t release = 0;
    };
    std::map<int, Acted> acted_;  // per control slot
};

}  // namespace irp::watch
