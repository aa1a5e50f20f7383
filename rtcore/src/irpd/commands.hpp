// commands.hpp -- the control protocol's commands (docs/control-protocol.md), on the control
// thread.  Reads (status, schedule, modules, stats, histograms, events, check) answer from the
// running generation and the shared-memory stats block; changes (load, change, set_period,
// set_priority, enable, disable) run on the main thread through the MainQueue; write goes through libindurop's
// locked path access; trace configures the trace rings (docs/trace-and-stream.md).
#pragma once

#include "control/control_server.hpp"
#include "events/event_log.hpp"
#include "irpd/main_queue.hpp"
#include "irpd/options.hpp"
#include "reload/reloader.hpp"
#include "stats/stats_segment.hpp"
#include "supervise/crash_record.hpp"
#include "trace/trace_rings.hpp"
#include "variables/variable_segment.hpp"

#include <string>

namespace irp::daemon {

struct CommandContext {
    reload::Reloader *reloader = nullptr;
    const stats::StatsSegment *stats = nullptr;
    events::EventLog *events = nullptr;
    MainQueue *queue = nullptr;
    const Options *options = nullptr;
    std::string variables_shm;  // "" = none
    nlohmann::json layout;      // the running layout.json (parsed), for write's type checks
    trace::TraceRings *trace = nullptr;
    const variables::VariableSegment *vars = nullptr;  // null: no shared variables
    supervise::CrashState *crash = nullptr;             // null: no state folder (no crash records)
};

control::Handler commandHandler(const CommandContext &context);

} // namespace irp::daemon
