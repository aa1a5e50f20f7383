// commands.hpp -- the control protocol's commands (docs/control-protocol.md), on the control
// thread.  Reads (status, schedule, modules, stats, histograms, events, check) answer from the
// running generation and the shared-memory stats block; changes (load, change, set_period,
// set_priority, enable, disable) run on the main thread through the MainQueue; write goes through libindurop's
// locked path access (refused for a forced variable); force, unforce and forces: irpd/forcing.hpp; trace configures the trace rings (docs/trace-and-stream.md); alarms reads
// the alarm segment's sources and the modules' declarations (docs/alarms.md); restart checks
// the set and hands a managed restart to the main thread (irpd/restart.hpp).
#pragma once

#include "alarms/alarm_segment.hpp"
#include "control/control_server.hpp"
#include "events/event_log.hpp"
#include "irpd/forcing.hpp"
#include "irpd/main_queue.hpp"
#include "irpd/options.hpp"
#include "irpd/restart.hpp"
#include "protocol/command_table.hpp"
#include "reload/reloader.hpp"
#include "retain/retain_store.hpp"
#include "stats/stats_segment.hpp"
#include "supervise/crash_record.hpp"
#include "trace/trace_rings.hpp"
#include "variables/variable_segment.hpp"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace irp::daemon {

// A request's command and arguments, checked (decodeCommand) before anything runs.
struct Command {
    using Kind = protocol::Cmd;  // one per command of protocol/control.json
    Kind kind = Kind::Status;
    std::string name;                                   // histograms: one record ("" = all)
    uint64_t since = 0;                                 // events
    std::size_t limit = protocol::kEventsDefaultLimit;  // events
    std::string config;                                 // check, load, restart: a module.xml path
    std::string set_id;                                 // load, restart
    std::string path;                                   // write: the variable
    nlohmann::json value;                 // write, force: its new value (checked against the layout when run)
    std::string by;                       // force: who forces
    bool restore = false;                 // unforce: write back the value before the force
    std::vector<reload::Change> changes;  // change; set_period, set_priority, enable, disable: one
    bool dry_run = false;                 // change
};

// The command `cmd` with the arguments of `request`, or an Error naming the argument to fix: the
// arguments are checked against protocol/control.json's description (protocol/arguments.hpp),
// then taken.  Touches nothing (no generation, no shared memory): tests/fuzz/fuzz_control.cpp
// runs it on arbitrary requests.  `trace`'s channels are looked up when it runs
// (trace::handleTraceCommand).
Result<Command> decodeCommand(const std::string &cmd, const nlohmann::json &request);

struct CommandContext {
    reload::Reloader *reloader = nullptr;
    const stats::StatsSegment *stats = nullptr;
    events::EventLog *events = nullptr;
    MainQueue *queue = nullptr;
    const Options *options = nullptr;
    std::string variables_shm;  // "" = none
    trace::TraceRings *trace = nullptr;
    const alarms::AlarmSegment *alarms = nullptr;
    const variables::VariableSegment *vars = nullptr;  // null: no shared variables
    std::function<std::string()> stopped_by;           // why a fault stopped the set ("" = it did not)
    supervise::CrashState *crash = nullptr;            // null: no state folder (no crash records)
    RestartDesk *restarts = nullptr;                   // null: `restart` is refused
    const retain::RetainStore *retain = nullptr;       // null: no retain store (docs/retain.md)
    Forcing *forcing = nullptr;                        // null: nothing may be forced (docs/forcing.md)
};

control::Handler commandHandler(const CommandContext &context);

}  // namespace irp::daemon
