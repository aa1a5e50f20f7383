// event_watch.cpp -- new counts of the stats block and the supervisor turned into events; see
// event_watch.hpp.
#include "irpd/watch/event_watch.hpp"

namespace irp::watch {

void EventWatch::look(const reload::Generation &g, const std::vector<hosts::ProcessInfo> &processes, bool figures) {
    for (const config::ModuleSpec &m : g.set.modules) {
        const stats::TimingRecord &r = stats_.record(g.members[static_cast<std::size_t>(m.index)].record);
        Seen &seen = seen_[m.name];
        const uint64_t errors = r.errors.load(), missed = r.missed.load(), overruns = r.overruns.load();
        // (on the first look too: a module may throw before it, in its first runs)
        if (errors > seen.errors) {
            const reload::Member &member = g.members[static_cast<std::size_t>(m.index)];
            const std::string text = member.thread ? member.thread->faultNote().read() : "";
            log_.add("fault", m.name,
                     "threw from " + (text.empty() ? std::string("run() or condition()") : text) +
                         "; disabled (enable it to run it again)");
        }
        if (figures || seen.first) {
            if (missed > seen.missed && !seen.first)
                log_.add("deadline", m.name,
                         std::to_string(missed - seen.missed) + " deadline misses (" + std::to_string(missed) +
                             " in all)");
            // (a module with <on_overrun> has each overrun reported by the watchdog instead)
            if (overruns > seen.overruns && !seen.first && m.on_overrun == config::OverrunAction::None)
                log_.add("overrun", m.name,
                         std::to_string(overruns - seen.overruns) + " budget overruns (" + std::to_string(overruns) +
                             " in all)");
            seen.missed = missed;
            seen.overruns = overruns;
        }
        seen.errors = errors;
        seen.first = false;
    }
    for (const hosts::ProcessInfo &p : processes) {
        Seen &seen = seen_["process:" + p.name + ":" + std::to_string(p.slot)];
        if (p.exits > seen.exits) log_.add("process_exit", p.name, p.last_exit);
        if (p.restarts > seen.restarts)
            log_.add("process_restart", p.name, "restarted (" + std::to_string(p.restarts) + " restarts)");
        if (p.dropped_lines > seen.dropped && figures)  // at most one a second
            log_.add("process_output_dropped", p.name,
                     std::to_string(p.dropped_lines - seen.dropped) + " output lines dropped by the rate limit (" +
                         std::to_string(p.dropped_lines) + " in all)");
        seen.exits = p.exits;
        seen.restarts = p.restarts;
        if (figures) seen.dropped = p.dropped_lines;
    }
}

}  // namespace irp::watch
