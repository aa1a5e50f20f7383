// fault_stop.cpp -- safe outputs for a stopped set, and the overrun watchdog's hooks; see
// fault_stop.hpp.
#include "irpd/watch/fault_stop.hpp"

#include "irpd/say.hpp"
#include "osal/clock.hpp"

namespace irp::watch {

std::size_t driveSafeOutputs(const reload::Generation &g, stats::StatsSegment &stats, events::EventLog &events) {
    std::size_t driven = 0;
    for (const config::ModuleSpec &m : g.set.modules) {
        const reload::Member &member = g.members[static_cast<std::size_t>(m.index)];
        stats.record(member.record).state.store(static_cast<uint32_t>(stats::ModuleState::Stopped));
        if (!member.thread || !member.thread->hasSafeOutputs()) continue;
        if (Status s = member.thread->safeOutputs(); !s) {
            events.add("safe_outputs_failed", m.name, s.error().message);
            daemon::say(s.error().message);
            continue;
        }
        ++driven;
    }
    return driven;
}

dispatch::Watchdog::Hooks watchdogHooks(events::EventLog &events, CurrentGeneration current,
                                        stats::StatsSegment &stats) {
    dispatch::Watchdog::Hooks hooks;
    hooks.report = [&events](const dispatch::Fault &f) {
        events.add("overrun", f.module(), f.describe());
        if (f.action == config::OverrunAction::Stop || f.kind == dispatch::Fault::Kind::Running)
            daemon::say("module '" + f.module() + "': " + f.describe());
    };
    hooks.stop = [&events, current = std::move(current), &stats](const dispatch::Fault &f) {
        const int64_t begun = osal::monotonicNow();
        const auto g = current();  // keeps the modules loaded while their hooks run
        const std::size_t driven = g ? driveSafeOutputs(*g, stats, events) : 0;
        const int64_t took = osal::monotonicNow() - begun;
        const std::string message = "set stopped by a fault of module '" + f.module() + "': outputs of " +
                                    std::to_string(driven) + " module(s) driven to safe values in " +
                                    std::to_string(took / 1000) + " us (" +
                                    std::to_string((begun - f.started_ns - f.limit_ns) / 1000) +
                                    " us after the overrun limit); restart irpd to run the set again";
        events.add("stopped", f.module(), message);
        daemon::say(message);
    };
    return hooks;
}

}  // namespace irp::watch
