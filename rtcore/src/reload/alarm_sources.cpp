// alarm_sources.cpp -- sources of the alarm segment by module name (see alarm_sources.hpp).
#include "reload/alarm_sources.hpp"

#include "protocol/limits.hpp"
#include "sdk/runtime.hpp"

#include <set>

namespace irp::reload {

alarms::Bitmap declaredIds(const config::ModuleSpec &m, const Member &member) {
    alarms::Bitmap bits{};
    for (const config::AlarmSpec &a : m.alarms) alarms::setBit(bits, a.id);
    if (member.thread)
        for (const runtime::AlarmDeclaration &d : runtime::alarmsOf(member.thread->instance()))
            alarms::setBit(bits, d.id);
    return bits;
}

Status assignAlarmSources(alarms::AlarmSegment &segment, Generation &next, const Generation *running) {
    std::set<uint32_t> taken{alarms::kIrpdSource};
    if (running)
        for (const Member &member : running->members) taken.insert(member.alarm_source);
    uint32_t free = 1;
    for (const config::ModuleSpec &m : next.set.modules) {
        Member &member = next.members[static_cast<std::size_t>(m.index)];
        const alarms::Bitmap from_xml = declaredIds(m, Member{});
        if (const int old = running ? running->find(m.name) : -1; old >= 0) {
            member.alarm_source = running->members[static_cast<std::size_t>(old)].alarm_source;
            if (!member.kept) segment.declare(member.alarm_source, from_xml, true);
            continue;
        }
        while (taken.count(free)) ++free;
        if (free >= segment.sourceMax())
            return Error{"no room for module '" + m.name + "' in irpd's alarm segment (" +
                             std::to_string(segment.sourceMax() - 1) +
                             " module sources, shared by the running set and the new one until the swap): "
                             "restart irpd onto this set",
                         protocol::kRestartRequired};
        taken.insert(free);
        member.alarm_source = free;
        member.alarm_claimed = true;
        segment.claim(free, m.name, from_xml);
    }
    return Ok{};
}

void settleAlarmSources(alarms::AlarmSegment &segment, const Generation &next, const Generation &old) {
    std::set<uint32_t> in_use;
    for (const config::ModuleSpec &m : next.set.modules) {
        const Member &member = next.members[static_cast<std::size_t>(m.index)];
        segment.declare(member.alarm_source, declaredIds(m, member));
        in_use.insert(member.alarm_source);
    }
    for (const Member &member : old.members)
        if (member.alarm_source && !in_use.count(member.alarm_source)) segment.release(member.alarm_source);
}

void undoAlarmSources(alarms::AlarmSegment &segment, Generation &partial, const Generation *running) {
    for (Member &member : partial.members) {
        if (member.alarm_claimed) segment.release(member.alarm_source);
        member.alarm_source = 0;
        member.alarm_claimed = false;
    }
    if (running)
        for (const config::ModuleSpec &m : running->set.modules) {
            const Member &member = running->members[static_cast<std::size_t>(m.index)];
            if (member.alarm_source) segment.declare(member.alarm_source, declaredIds(m, member));
        }
}

}  // namespace irp::reload
