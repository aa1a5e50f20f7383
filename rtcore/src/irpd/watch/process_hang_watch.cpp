// process_hang_watch.cpp -- a process module's release in flight past its overrun limit, acted
// on once; see process_hang_watch.hpp.
#include "irpd/watch/process_hang_watch.hpp"

#include "irpd/say.hpp"

#include <atomic>

namespace irp::watch {

void ProcessHangWatch::look(const reload::Generation &g, hosts::ControlSegment &control, events::EventLog &log,
                            stats::StatsSegment &stats, const HangActions &act, int64_t now) {
    for (const config::ModuleSpec &m : g.set.modules) {
        const reload::Member &member = g.members[static_cast<std::size_t>(m.index)];
        if (m.type != config::ModuleType::Process || m.on_overrun == config::OverrunAction::None || member.slot < 0)
            continue;
        indurop_process_slot &slot = control.slot(static_cast<uint32_t>(member.slot));
        const uint32_t released = std::atomic_ref<uint32_t>(slot.release_seq).load(std::memory_order_acquire);
        if (std::atomic_ref<uint32_t>(slot.done_seq).load(std::memory_order_acquire) == released) continue;
        const int64_t since = std::atomic_ref<int64_t>(slot.release_ns).load(std::memory_order_relaxed);
        if (now - since <= m.overrun_limit_ns) continue;
        const uint64_t generation = std::atomic_ref<uint64_t>(slot.generation).load(std::memory_order_relaxed);
        Acted &acted = acted_[member.slot];
        if (acted.generation == generation && acted.release == released) continue;
        acted = {generation, released};
        dispatch::Fault f;
        f.action = m.on_overrun;
        f.record = &stats.record(member.record);
        f.executor = "process";
        f.started_ns = since;
        f.limit_ns = m.overrun_limit_ns;
        f.elapsed_ns = now - since;
        f.seen_ns = now;
        std::string message = "release not completed after " + std::to_string((now - since) / 1000) +
                              " us, past its overrun limit " + std::to_string(m.overrun_limit_ns / 1000) +
                              " us (on_overrun=" + config::toString(m.on_overrun) + ")";
        if (m.on_overrun == config::OverrunAction::Restart) {
            const auto info = act.process ? act.process(m.name) : std::nullopt;
            if (info && info->running && info->pid > 0) {
                act.kill(info->pid);  // reaped by poll(), restarted per its `restart` property
                message += ": killed (pid " + std::to_string(info->pid) + "), restarted per its restart policy";
            }
        } else if (m.on_overrun == config::OverrunAction::Stop) {
            message += ": set stopped, outputs driven to safe values";
        }
        log.add("process_hang", m.name, message);
        daemon::say("module '" + m.name + "': " + message);
        if (m.on_overrun == config::OverrunAction::Stop) act.stop_set(f);
    }
}

}  // namespace irp::watch
