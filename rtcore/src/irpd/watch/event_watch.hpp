// event_watch.hpp -- turns what the RT threads and the process supervisor counted since the last
// look into events (docs/faults.md): a module disabled by a fault (at once, also on the first
// look), deadline misses and budget overruns (at most one event per module per second: on the
// looks with `figures`), process exits and restarts (at once), and the output lines a process
// lost to the rate limit (at most one a second).  A module with <on_overrun> has each overrun
// reported by the watchdog instead.  Main thread, every tick.
#pragma once

#include "events/event_log.hpp"
#include "hosts/process_supervisor.hpp"
#include "reload/generation.hpp"
#include "stats/stats_segment.hpp"

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace irp::watch {

class EventWatch {
public:
    EventWatch(events::EventLog &log, const stats::StatsSegment &stats) : log_(log), stats_(stats) {}

    // One look at the generation's modules and the supervisor's processes.  figures: the
    // once-a-second look at misses, overruns and dropped output.
    void look(const reload::Generation &g, const std::vector<hosts::ProcessInfo> &processes, bool figures);

private:
    struct Seen {
        bool first = true;
        uint64_t errors = 0, missed = 0, overruns = 0, exits = 0, restarts = 0, dropped = 0;
    };
    events::EventLog &log_;
    const stats::StatsSegment &stats_;
    std::map<std::string, Seen> seen_;  // by module name, and "process:<name>:<slot>"
};

}  // namespace irp::watch
