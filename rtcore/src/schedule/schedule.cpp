// schedule.cpp -- builds, prints and serializes the slot table.
#include "schedule/schedule.hpp"

#include "protocol/limits.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <numeric>
#include <sstream>

namespace irp::schedule {

using config::ModuleSpec;
using config::OperationType;

Result<Schedule> build(const config::SetSpec &set, const Limits &limits) {
    std::vector<const ModuleSpec *> periodic;
    for (const ModuleSpec &m : set.modules)
        if (m.operation == OperationType::Periodic) periodic.push_back(&m);
    if (periodic.empty())
        return fileError(set.xml_path.string(), "no periodic module, so there is no basic period to run the set on");

    Schedule s;
    s.basic_ns = periodic.front()->period_ns;
    s.macro_ns = periodic.front()->period_ns;
    const ModuleSpec *longest = periodic.front();
    for (const ModuleSpec *m : periodic) {
        s.basic_ns = std::gcd(s.basic_ns, m->period_ns);
        int64_t factor = m->period_ns / std::gcd(s.macro_ns, m->period_ns);
        if (__builtin_mul_overflow(s.macro_ns, factor, &s.macro_ns))
            return Error{set.xml_path.string() + ":" + std::to_string(m->line) + ": module '" + m->name +
                             "': the periods have no common multiple below 2^63 ns; choose harmonic periods",
                         protocol::kRefused, Place{set.xml_path.string(), m->line, 0, m->name, "period"}};
        if (m->period_ns > longest->period_ns) longest = m;
    }
    if (s.basic_ns < limits.min_basic_ns)
        return fileError(set.xml_path.string(),
                         "the basic period (GCD of the periods) is " + std::to_string(s.basic_ns) +
                             " ns, below the minimum basic period of " + std::to_string(limits.min_basic_ns) +
                             " ns; make the periods multiples of at least " + humanDuration(limits.min_basic_ns));
    const int64_t count = s.macro_ns / s.basic_ns;
    if (static_cast<uint64_t>(count) > limits.max_slots)
        return fileError(set.xml_path.string(), "the macro period (LCM of the periods) is " +
                                                    std::to_string(s.macro_ns) + " ns, " + std::to_string(count) +
                                                    " basic periods of " + std::to_string(s.basic_ns) +
                                                    " ns; at most " + std::to_string(limits.max_slots) +
                                                    " are allowed: choose periods that are multiples of each other");

    // Run order inside a slot: priority, then position in the file.
    std::stable_sort(periodic.begin(), periodic.end(), [](const ModuleSpec *a, const ModuleSpec *b) {
        return a->priority != b->priority ? a->priority < b->priority : a->index < b->index;
    });
    s.slots.resize(static_cast<std::size_t>(count));
    for (int64_t i = 0; i < count; ++i) {
        Slot &slot = s.slots[static_cast<std::size_t>(i)];
        slot.index = static_cast<std::size_t>(i);
        slot.offset_ns = i * s.basic_ns;
        for (const ModuleSpec *m : periodic)
            if (slot.offset_ns % m->period_ns == 0) slot.modules.push_back(m->index);
    }
    return s;
}

std::string humanDuration(int64_t ns) {
    struct Unit {
        int64_t scale;
        const char *name;
    };
    static constexpr Unit units[] = {{1'000'000'000, "s"}, {1'000'000, "ms"}, {1'000, "us"}, {1, "ns"}};
    for (const Unit &u : units) {
        if (ns >= u.scale || u.scale == 1) {
            char buf[48];
            if (ns % u.scale == 0)
                std::snprintf(buf, sizeof buf, "%lld %s", static_cast<long long>(ns / u.scale), u.name);
            else
                std::snprintf(buf, sizeof buf, "%.3g %s", static_cast<double>(ns) / static_cast<double>(u.scale),
                              u.name);
            return buf;
        }
    }
    return std::to_string(ns) + " ns";
}

namespace {

std::string shownName(const ModuleSpec &m) {
    return m.executor == config::kMainExecutor ? m.name : m.name + "@" + m.executor;
}

}  // namespace

std::string formatText(const Schedule &s, const config::SetSpec &set) {
    std::ostringstream out;
    out << "basic period " << s.basic_ns << " ns (" << humanDuration(s.basic_ns) << "), macro period " << s.macro_ns
        << " ns (" << humanDuration(s.macro_ns) << "), " << s.slots.size() << " slot"
        << (s.slots.size() == 1 ? "" : "s") << "\n";
    out << "slot  offset_ns    modules (in priority order)\n";
    for (const Slot &slot : s.slots) {
        char head[40];
        std::snprintf(head, sizeof head, "%-5zu %-12lld ", slot.index, static_cast<long long>(slot.offset_ns));
        out << head;
        for (std::size_t i = 0; i < slot.modules.size(); ++i)
            out << (i ? " > " : "") << shownName(set.modules[static_cast<std::size_t>(slot.modules[i])]);
        out << "\n";
    }
    bool header = false;
    for (const ModuleSpec &m : set.modules) {
        if (m.operation == OperationType::Periodic) continue;
        if (!header) out << "outside the slot table:\n";
        header = true;
        out << "  " << shownName(m) << " (" << config::toString(m.operation) << " " << config::toString(m.type);
        if (m.operation == OperationType::Sporadic)
            out << ", deadline " << m.deadline_ns << " ns, priority " << m.priority << ", checked every basic period";
        else
            out << ", runs in the time left over";
        out << ")\n";
    }
    bool any_executor = std::any_of(set.modules.begin(), set.modules.end(),
                                    [](const ModuleSpec &m) { return m.executor != config::kMainExecutor; });
    if (any_executor) out << "name@executor: the module runs on that executor's own dispatcher thread, same slots\n";
    return out.str();
}

nlohmann::ordered_json toJson(const Schedule &s, const config::SetSpec &set) {
    nlohmann::ordered_json slots = nlohmann::ordered_json::array();
    for (const Slot &slot : s.slots) {
        nlohmann::ordered_json names = nlohmann::ordered_json::array();
        for (int i : slot.modules) names.push_back(set.modules[static_cast<std::size_t>(i)].name);
        slots.push_back({{"index", slot.index}, {"offset_ns", slot.offset_ns}, {"modules", std::move(names)}});
    }
    nlohmann::ordered_json modules = nlohmann::ordered_json::array();
    for (const ModuleSpec &m : set.modules) {
        modules.push_back({{"name", m.name},
                           {"moduletype", config::toString(m.type)},
                           {"operationtype", config::toString(m.operation)},
                           {"period_ns", m.period_ns},
                           {"deadline_ns", m.deadline_ns},
                           {"priority", m.priority},
                           {"executor", m.executor}});
    }
    return {{"basic_period_ns", s.basic_ns},
            {"macro_period_ns", s.macro_ns},
            {"slots", std::move(slots)},
            {"modules", std::move(modules)}};
}

}  // namespace irp::schedule
