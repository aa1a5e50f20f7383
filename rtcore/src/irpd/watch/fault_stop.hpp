// fault_stop.hpp -- what irpd does when a fault stops the set (docs/faults.md) and at a managed
// restart's stop (docs/hot-reload.md): every module of the running generation marked stopped and
// its safe_outputs() called; and the overrun watchdog's hooks, which report each overrun as an
// event and run that stop from the watchdog's thread.
#pragma once

#include "dispatch/watchdog.hpp"
#include "events/event_log.hpp"
#include "reload/generation.hpp"
#include "stats/stats_segment.hpp"

#include <cstddef>
#include <functional>
#include <memory>

namespace irp::watch {

// Every module of `g` marked stopped and, for those that have one, its safe_outputs() called (on
// the calling thread).  How many drove their outputs; a hook that failed is a
// "safe_outputs_failed" event.  The caller keeps `g` (and so its modules) alive meanwhile.
std::size_t driveSafeOutputs(const reload::Generation &g, stats::StatsSegment &stats, events::EventLog &events);

// The running generation, asked when a stop happens (the reloader's current()).
using CurrentGeneration = std::function<std::shared_ptr<const reload::Generation>()>;

// The watchdog's hooks: every overrun is an "overrun" event (and a line on irpd's log when it
// stops the set or is seen while running); a stop drives every module's outputs to safe values
// at once and says so ("stopped" event).
dispatch::Watchdog::Hooks watchdogHooks(events::EventLog &events, CurrentGeneration current,
                                        stats::StatsSegment &stats);

}  // namespace irp::watch
