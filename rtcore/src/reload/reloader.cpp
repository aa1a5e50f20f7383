// reloader.cpp -- prepare, swap, retire (see reloader.hpp).
#include "reload/reloader.hpp"

#include "hosts/module_identity.hpp"
#include "osal/clock.hpp"
#include "osal/rt.hpp"
#include "protocol/errors.hpp"
#include "reload/alarm_sources.hpp"
#include "sdk/runtime.hpp"
#include "stats/summary.hpp"
#include "variables/layout.hpp"

#include <algorithm>
#include <map>
#include <sstream>
#include <thread>

namespace irp::reload {
namespace {

using json = nlohmann::ordered_json;

using config::errorAbout;

// Whether executor `name` is the same thread in both sets: the same priority and CPU.
bool sameThread(const std::vector<dispatch::ExecutorOptions> &a, const std::vector<dispatch::ExecutorOptions> &b,
                const std::string &name) {
    auto named = [&](const std::vector<dispatch::ExecutorOptions> &list) {
        return std::find_if(list.begin(), list.end(), [&](const auto &e) { return e.name == name; });
    };
    auto x = named(a), y = named(b);
    return x != a.end() && y != b.end() && x->rt_priority == y->rt_priority && x->cpu == y->cpu;
}

// A module of the new set that can stay the running instance: the same code (its loadable sections,
// hosts/module_identity.hpp), kind and properties (they go to initialize()); a process also the same
// executor thread (it runs at that executor's RT priority minus one, on its CPU): same_thread.
bool keepable(const config::ModuleSpec &next, const std::string &next_identity, const config::ModuleSpec &old,
              const Member &old_member, bool same_thread) {
    if (next.type != old.type || next.operation != old.operation || next_identity != old_member.identity ||
        next.properties != old.properties || !config::sameAlarms(next, old))
        return false;
    return next.type == config::ModuleType::Thread || (next.executor == old.executor && same_thread);
}

json names(const std::vector<std::string> &list) { return json(list); }

// The paths of `list` a user sees: a compiler's own variables (layout.json's "internal": true, stc's
// init flags) are added, zeroed and kept like any other, but the reports leave them out.
json shown(const std::vector<std::string> &list, const std::vector<std::string> &internal) {
    json out = json::array();
    for (const std::string &p : list)
        if (std::find(internal.begin(), internal.end(), p) == internal.end()) out.push_back(p);
    return out;
}

json variablesJson(const Generation &g) {
    json moved = json::array(), converted = json::array();
    for (const layouts::Moved &m : g.variables.moved) {
        moved.push_back({{"path", m.path}, {"from", m.from}, {"to", m.to}});
        if (const auto why = g.conversions.not_converted.find(m.path); why != g.conversions.not_converted.end()) {
            moved.back()["reason"] = why->second.reason;
            if (!why->second.from_type.empty()) moved.back()["from_type"] = why->second.from_type;
            if (!why->second.to_type.empty()) moved.back()["to_type"] = why->second.to_type;
        }
    }
    for (const variables::Conversion &c : g.conversions.converted)
        converted.push_back(
            {{"path", c.path}, {"from_type", c.from_type}, {"to_type", c.to_type}, {"dropped", c.dropped}});
    return json{{"layout", g.layout ? json(g.layout->hash) : json(nullptr)},
                {"added", shown(g.variables.added, g.variables.internal)},
                {"removed", shown(g.variables.removed, g.variables.internal)},
                {"moved", moved},
                {"converted", converted},
                {"replaced", g.replaced_for_layout}};
}

// A retyped variable whose value cannot be converted without loss is not swapped in online (its
// value would be lost while the set runs on): restart_required, naming each with its types, and the
// managed restart runs the set, every variable afresh (docs/hot-reload.md "Converted variables").
Status retypedNeedRestart(const Generation &g) {
    if (g.variables.moved.empty()) return Ok{};
    std::string list;
    for (const layouts::Moved &m : g.variables.moved) {
        const auto why = g.conversions.not_converted.find(m.path);
        list += (list.empty() ? "" : "; ") + ("'" + m.path + "'");
        if (why == g.conversions.not_converted.end()) {
            list += " (the set's layout was not compiled against the running one)";
            continue;
        }
        if (!why->second.from_type.empty() && !why->second.to_type.empty())
            list += " " + why->second.from_type + " -> " + why->second.to_type;
        list += " (" + why->second.reason + ")";
    }
    return Error{"the type of variable" + std::string(g.variables.moved.size() > 1 ? "s " : " ") + list +
                     " changes and the value cannot be converted without loss: only the managed restart "
                     "(activate --mode restart or auto) runs this set, every variable starting afresh (at its "
                     "initial value, else zero); to keep the value online, convert it in the program instead",
                 protocol::kRestartRequired};
}

int64_t now() { return osal::monotonicNow(); }

// What a generation does to the modules of the one running: kept (the same instance), started (a
// new instance), stopped (the running instance goes), and replaced: the names in both sets that are
// not kept (each also in started and stopped: its running instance stops, a new one starts afresh).
struct Fates {
    std::vector<std::string> kept, started, stopped, replaced;
};
Fates fatesOf(const Generation &next, const Generation *running) {
    Fates f;
    for (const config::ModuleSpec &m : next.set.modules) {
        const bool kept = next.members[static_cast<std::size_t>(m.index)].kept;
        (kept ? f.kept : f.started).push_back(m.name);
        if (!kept && running && running->find(m.name) >= 0) f.replaced.push_back(m.name);
    }
    if (running)
        for (const config::ModuleSpec &m : running->set.modules) {
            const int n = next.find(m.name);
            if (n < 0 || !next.members[static_cast<std::size_t>(n)].kept) f.stopped.push_back(m.name);
        }
    return f;
}

}  // namespace

void resolveLayout(config::SetSpec &set, const std::filesystem::path &override_path) {
    if (!override_path.empty()) set.layout = override_path;
    const auto beside = set.xml_path.parent_path() / "layout.json";
    std::error_code ec;
    if (set.layout.empty() && std::filesystem::is_regular_file(beside, ec)) set.layout = beside;
}

json scheduleJson(const Generation &g) {
    json j = schedule::toJson(g.schedule, g.set);
    for (json &m : j["modules"]) m["enabled"] = g.disabled.count(m["name"].get<std::string>()) == 0;
    return j;
}

// What can be checked before loading anything: the modules' files and their layout stamps, the
// layout against the running segment, the executors, the process slots.  out (optional) gets the
// set's layout, its diff against the segment's, and every module's identity (members).
Status Reloader::checkAgainst(const config::SetSpec &set, const Generation *running, Generation *out) const {
    for (const config::ModuleSpec &m : set.modules) {
        std::error_code ec;
        if (!std::filesystem::is_regular_file(m.path, ec))
            return errorAbout(m, "<filename> " + m.filename + " -> " + m.path.string() + " does not exist", "filename");
        if (m.type == config::ModuleType::Thread && m.operation == config::OperationType::NonReal)
            return errorAbout(m,
                              "a non-real module runs in the time left over as a process: set "
                              "<moduletype>process</moduletype>",
                              "moduletype");
    }
    std::shared_ptr<const variables::Layout> layout;
    if (!set.layout.empty()) {
        auto read = variables::readLayout(set.layout);
        if (!read) return read.error();
        layout = std::make_shared<const variables::Layout>(std::move(*read));
    }
    // Every module's layout stamp against the layout the set would run with (its own, else the
    // running one), before anything about the running set: a module that does not fit it runs
    // neither online nor after a restart, so `check` refuses it with load's very error.
    const std::shared_ptr<const variables::Layout> segment_layout = s_.vars ? s_.vars->layout() : nullptr;
    const layouts::Model *model = layout                       ? &layout->model
                                  : running && running->layout ? &running->layout->model
                                  : segment_layout             ? &segment_layout->model
                                                               : nullptr;
    std::vector<Member> members(set.modules.size());
    for (const config::ModuleSpec &m : set.modules) {
        auto identity = hosts::identify(m.path);
        if (!identity) return errorAbout(m, identity.error().message);
        if (Status st = hosts::builtLayoutFits(m, identity->layout, model); !st) return st.error();
        members[static_cast<std::size_t>(m.index)].identity = identity->code;
        members[static_cast<std::size_t>(m.index)].layout = identity->layout;
    }
    layouts::Diff d;
    if (layout) {
        if (!s_.vars)
            return Error{"the set declares shared variables (" + set.layout.string() +
                             ") but irpd runs without a variable segment: a restart onto this set makes one",
                         protocol::kRestartRequired};
        d = layouts::diff(s_.vars->layout()->model, layout->model);
        if (!d.online_impossible.empty())
            return Error{"the set's shared-variable layout " + layout->hash.substr(0, 12) + "… (" +
                             set.layout.string() + ") cannot replace the running one online: " + d.online_impossible,
                         protocol::kRestartRequired};
        if (std::string why = s_.vars->fits(*layout); !why.empty()) return Error{why, protocol::kRestartRequired};
    }
    variables::Conversions conversions;
    if (layout) {
        auto planned = variables::conversionsOf(*layout, s_.vars->layout()->model, d.moved);
        if (!planned) return planned.error();
        conversions = std::move(*planned);
        std::erase_if(d.moved, [&](const layouts::Moved &m) {
            return std::any_of(conversions.converted.begin(), conversions.converted.end(),
                               [&](const variables::Conversion &c) { return c.path == m.path; });
        });
    }
    if (Status st = dispatch::checkExecutors(dispatch::executorsOf(set, s_.dispatcher)); !st) return st.error();
    std::size_t processes = 0;
    for (const config::ModuleSpec &m : set.modules) processes += m.type == config::ModuleType::Process;
    if (running && s_.control && processes > s_.control->slotCount())
        return Error{"the set has " + std::to_string(processes) + " process modules; this irpd has room for " +
                         std::to_string(s_.control->slotCount()) +
                         " (irpd's --process-slots, by default the larger of "
                         "16 and the first set's): a restart onto this set makes room",
                     protocol::kRestartRequired};
    if (out) {
        out->layout = std::move(layout);
        out->variables = std::move(d);
        out->conversions = std::move(conversions);
        out->members = std::move(members);
    }
    return Ok{};
}

// Room in the stats block for what a swap adds, before anything is loaded: realize() takes a record
// for each new module (past the records irpd started with for its executors), then the
// dispatcher's prepare() one for each new executor thread (any free record).  Records of what the
// swap stops are freed only after it.
Status Reloader::checkRecordRoom(const Generation &next, const std::vector<dispatch::ExecutorOptions> &threads,
                                 const std::vector<dispatch::ExecutorOptions> &running_threads) const {
    if (!s_.stats) return Ok{};
    std::vector<std::string> needing;
    std::size_t modules = 0;
    for (const config::ModuleSpec &m : next.set.modules)
        if (!next.members[static_cast<std::size_t>(m.index)].kept) {
            needing.push_back("module '" + m.name + "'");
            ++modules;
        }
    for (const dispatch::ExecutorOptions &e : threads)
        if (!sameThread(threads, running_threads, e.name)) needing.push_back("executor '" + e.name + "'");
    const std::size_t for_modules = s_.stats->countUnused(s_.executors), in_all = s_.stats->countUnused(1);
    if (modules <= for_modules && needing.size() <= in_all) return Ok{};
    std::string list;
    for (const std::string &n : needing) list += (list.empty() ? "" : ", ") + n;
    return Error{"no room in irpd's stats block for " + list + " (" + std::to_string(needing.size()) + " needed, " +
                     std::to_string(in_all) + " free of its " + std::to_string(s_.stats->recordCount()) +
                     " records for dispatchers and modules; irpd's --module-records raises it): restart irpd onto "
                     "this set, or with a larger --module-records",
                 protocol::kRestartRequired};
}

json Reloader::check(const std::filesystem::path &xml) const {
    json errors = json::array(), problems = json::array(), warnings = json::array(), schedule_json = nullptr,
         variables = nullptr, restart = nullptr, modules = nullptr;
    // Each error as its sentence (errors) and with its place as fields (problems).
    const auto refuse = [&](const Error &e) {
        errors.push_back(e.message);
        problems.push_back(protocol::problemJson(e));
    };
    auto set = config::parseModuleXml(xml);
    if (!set) {
        refuse(set.error());
    } else {
        // An executor on a CPU that irpd's non-RT threads were not kept off at start shares it with them.
        if (!s_.kept_off.empty())
            for (const dispatch::ExecutorOptions &e : dispatch::executorsOf(*set, s_.dispatcher))
                if (!s_.kept_off.count(e.cpu))
                    warnings.push_back("executor '" + e.name + "' runs on CPU " + std::to_string(e.cpu) +
                                       ", which irpd's non-RT threads were not kept off when it started: "
                                       "they share it until irpd restarts onto this set");
        resolveLayout(*set);
        auto schedule = schedule::build(*set, s_.limits);
        if (!schedule)
            refuse(schedule.error());
        else
            schedule_json = schedule::toJson(*schedule, *set);
        // The plan of a load, without loading: which modules stay, what the layout changes.
        const auto running = current();
        if (!schedule) {  // still say what else is wrong
            if (Status st = checkAgainst(*set, running.get()); !st && st.error().code != protocol::kRestartRequired)
                refuse(st.error());
        } else if (auto planned = plan(*set, running.get(), running ? running->disabled : std::set<std::string>{}, "");
                   !planned) {
            if (planned.error().code == protocol::kRestartRequired)
                restart = json{{"reason", planned.error().message}};
            else
                refuse(planned.error());
        } else {
            if ((*planned)->layout) variables = variablesJson(**planned);
            if (Status st = retypedNeedRestart(**planned); !st) restart = json{{"reason", st.error().message}};
            const Fates f = fatesOf(**planned, running.get());
            modules = json{{"kept", f.kept}, {"started", f.started}, {"stopped", f.stopped}, {"replaced", f.replaced}};
        }
    }
    // A set that only a restart can run is valid: activation offers the restart (docs/hot-reload.md).
    return json{{"valid", errors.empty()}, {"errors", errors},          {"problems", problems},
                {"warnings", warnings},    {"schedule", schedule_json}, {"online", errors.empty() && restart.is_null()},
                {"restart", restart},      {"variables", variables},    {"modules", modules}};
}

Result<std::unique_ptr<Generation>> Reloader::prepare(config::SetSpec set, const Generation *running,
                                                      std::set<std::string> disabled, std::string set_id,
                                                      const std::function<Status(Generation &)> &before_processes) {
    auto next = plan(std::move(set), running, std::move(disabled), std::move(set_id));
    if (!next) return next.error();
    if (Status st = retypedNeedRestart(**next); !st) return st.error();
    if (Status st = realize(**next, running, before_processes); !st) return st.error();
    return next;
}

// Everything decided before anything is loaded: the schedule, the checks against the running set,
// which modules are kept, the estimated utilization.  No side effect: nothing to undo.
Result<std::unique_ptr<Generation>> Reloader::plan(config::SetSpec set, const Generation *running,
                                                   std::set<std::string> disabled, std::string set_id,
                                                   Estimate *estimate) const {
    auto schedule = schedule::build(set, s_.limits);
    if (!schedule) return schedule.error();
    Generation checked;
    if (Status st = checkAgainst(set, running, &checked); !st) return st.error();
    // A disabled module the new set no longer has is forgotten.
    std::erase_if(disabled, [&](const std::string &name) {
        return std::none_of(set.modules.begin(), set.modules.end(), [&](const auto &m) { return m.name == name; });
    });

    auto next = std::make_unique<Generation>();
    next->number = running ? running->number + 1 : 1;
    next->set_id = std::move(set_id);
    next->set = std::move(set);
    next->schedule = std::move(*schedule);
    next->disabled = std::move(disabled);
    next->members = std::move(checked.members);  // each module's identity and layout stamp
    next->layout = std::move(checked.layout);
    next->variables = std::move(checked.variables);
    next->conversions = std::move(checked.conversions);
    if (!next->layout && running && next->set.layout.empty()) next->layout = running->layout;
    const config::SetSpec &spec = next->set;

    // Which modules stay.  A running module that goes away must not own shared functions: kept
    // modules may hold pointers into its code (found in their start()).
    std::vector<bool> old_kept(running ? running->members.size() : 0, false);
    const std::vector<dispatch::ExecutorOptions> threads = dispatch::executorsOf(spec, s_.dispatcher);
    const std::vector<dispatch::ExecutorOptions> running_threads =
        running ? dispatch::executorsOf(running->set, s_.dispatcher) : std::vector<dispatch::ExecutorOptions>{};
    for (const config::ModuleSpec &m : spec.modules) {
        Member &member = next->members[static_cast<std::size_t>(m.index)];
        if (!running) continue;
        const int old = running->find(m.name);
        if (old < 0) continue;
        const auto o = static_cast<std::size_t>(old);
        if (!keepable(m, member.identity, running->set.modules[o], running->members[o],
                      sameThread(threads, running_threads, m.executor)))
            continue;
        // Its stamp fits the new layout (checkAgainst): the running instance addresses every
        // variable where the new layout has it.
        member.thread = running->members[o].thread;
        member.record = running->members[o].record;
        member.slot = running->members[o].slot;
        member.sha256 = running->members[o].sha256;  // the file it was loaded from (its module-cache copy)
        member.kept = true;
        old_kept[o] = true;
    }
    // Running modules that the new layout leaves no place for: they are replaced, not kept.
    if (running && next->layout && running->layout && next->layout->hash != running->layout->hash)
        for (std::size_t o = 0; o < old_kept.size(); ++o) {
            const Member &was = running->members[o];
            if (!old_kept[o] && !was.layout.empty() && !layouts::compatible(was.layout, next->layout->model).empty())
                next->replaced_for_layout.push_back(running->set.modules[o].name);
        }
    // A running exporter that goes away: the modules that keep running must not hold pointers into
    // its code (found by findFunction in their initialize() or start()).
    if (running)
        for (std::size_t o = 0; o < old_kept.size(); ++o) {
            const Member &was = running->members[o];
            if (old_kept[o] || !was.thread) continue;
            const std::vector<std::string> exported = runtime::exportsOf(was.thread->instance());
            if (exported.empty()) continue;
            const std::set<uint64_t> importers = runtime::importersOf(was.thread->instance());
            for (const config::ModuleSpec &m : spec.modules) {
                const Member &member = next->members[static_cast<std::size_t>(m.index)];
                if (!member.kept || !member.thread || !importers.count(member.thread->instance())) continue;
                std::string list;
                for (const std::string &f : exported) list += (list.empty() ? "" : ", ") + f;
                return Error{"module '" + m.name + "' keeps running and calls shared functions of module '" +
                                 running->set.modules[o].name + "' (" + list +
                                 ") through pointers it found at its "
                                 "start: replacing or removing '" +
                                 running->set.modules[o].name + "' online needs '" + m.name +
                                 "' replaced too; a restart does both",
                             protocol::kRestartRequired};
            }
        }

    if (running)
        if (Status st = checkRecordRoom(*next, threads, running_threads); !st) return st.error();

    // Estimated utilization per executor: measured exec p99 of kept modules, budget of new ones.
    Estimate own;
    Estimate &e = estimate ? *estimate : own;
    e.busy.clear();
    e.busy[config::kMainExecutor] = 0;
    for (const config::ExecutorSpec &x : spec.executors) e.busy[x.name] = 0;
    std::map<std::string, std::string> detail;
    for (const config::ModuleSpec &m : spec.modules) {
        if (m.operation != config::OperationType::Periodic || next->disabled.count(m.name)) continue;
        const Member &member = next->members[static_cast<std::size_t>(m.index)];
        double exec = static_cast<double>(m.budget_ns);
        if (member.kept) exec = std::max(exec, stats::quantile(s_.stats->record(member.record).exec, 0.99));
        if (exec <= 0) continue;
        const double share = exec / static_cast<double>(m.period_ns);
        e.busy[m.executor] += share;
        std::ostringstream part;
        part.precision(3);
        part << m.name << " " << share * 100 << " %";
        detail[m.executor] += (detail[m.executor].empty() ? "" : ", ") + part.str();
    }
    for (const auto &[executor, share] : e.busy)
        if (share > protocol::kUtilizationError) {
            std::ostringstream text;
            text.precision(3);
            text << "executor '" << executor << "' would be " << share * 100
                 << " % busy (execution time p99 of running modules, <budget> of new ones, over their periods: "
                 << detail[executor] << "): lengthen a period or move a module to another executor";
            return Error{text.str()};
        }
    return next;
}

// Loads what plan() decided to load: stats records, new thread modules (initialize, start), new
// processes; builds the executors' tables.  On failure undoes all of it.
Status Reloader::realize(Generation &generation, const Generation *running,
                         const std::function<Status(Generation &)> &before_processes) {
    Generation *next = &generation;
    const config::SetSpec &spec = next->set;

    // Stats records for the new modules.
    std::size_t from = s_.executors;
    std::vector<std::size_t> taken;
    for (const config::ModuleSpec &m : spec.modules) {
        Member &member = next->members[static_cast<std::size_t>(m.index)];
        if (member.kept) continue;
        auto free = s_.stats->findUnused(from);
        if (!free) {
            for (std::size_t r : taken) s_.stats->release(r);
            return Error{"no room for module '" + m.name + "' in irpd's stats block (" +
                             std::to_string(s_.stats->recordCount() - s_.executors) +
                             " module records, irpd's "
                             "--module-records): restart irpd onto this set, or with a larger --module-records",
                         protocol::kRestartRequired};
        }
        member.record = *free;
        from = *free + 1;
        taken.push_back(*free);
        s_.stats->describe(*free, stats::RecordKind::Module, m.name, m.executor, m.period_ns, m.priority, m.budget_ns)
            .state.store(static_cast<uint32_t>(stats::ModuleState::Loaded));
    }

    // Alarm sources, by name: the modules' initialize() and start() may raise and declare.
    if (s_.alarms)
        if (Status st = assignAlarmSources(*s_.alarms, *next, running); !st) {
            undo(*next);
            return st.error();
        }

    // A changed layout is published before anything new loads: the new variables are zeroed and
    // visible, the old ones stay where they are for the modules that keep running.
    if (next->layout && s_.vars && next->layout->hash != s_.vars->hash()) {
        std::vector<std::string> fresh = next->variables.added;
        for (const layouts::Moved &m : next->variables.moved) fresh.push_back(m.path);
        for (const variables::Conversion &c : next->conversions.converted) fresh.push_back(c.path);
        next->previous_layout = s_.vars->layout();
        if (Status st = s_.vars->publish(*next->layout, fresh); !st) {
            undo(*next);
            return st.error();
        }
        next->published = true;
    }

    // New thread modules: loaded from their content-addressed copies, initialized, started.
    const std::shared_ptr<const variables::Layout> segment_layout = s_.vars ? s_.vars->layout() : nullptr;
    const layouts::Model *model = next->layout     ? &next->layout->model
                                  : segment_layout ? &segment_layout->model
                                                   : nullptr;
    for (const config::ModuleSpec &m : spec.modules) {
        Member &member = next->members[static_cast<std::size_t>(m.index)];
        if (member.kept || m.type != config::ModuleType::Thread) continue;
        auto image = s_.cache->put(m.path);
        if (!image) {
            undo(*next);
            return errorAbout(m, image.error().message);
        }
        member.sha256 = image->sha256;
        auto loaded = hosts::ThreadModule::load(m, model, image->image);
        if (!loaded) {
            undo(*next);
            return loaded.error();
        }
        if (m.operation == config::OperationType::Sporadic && !(*loaded)->hasCondition()) {
            undo(*next);
            return errorAbout(m, "a sporadic thread module needs condition() (extern \"C\" int condition(), or "
                                 "INDUROP_MODULE(condition = ...)), which the event handler calls every basic period");
        }
        member.layout = (*loaded)->builtLayout();
        if (s_.alarms) (*loaded)->setAlarmSource(member.alarm_source);
        member.thread = std::move(*loaded);
    }
    for (auto phase : {&hosts::ThreadModule::initialize, &hosts::ThreadModule::start})
        for (Member &member : next->members)
            if (!member.kept && member.thread)
                if (Status st = ((*member.thread).*phase)(); !st) {
                    undo(*next);
                    return st.error();
                }
    if (before_processes)
        if (Status st = before_processes(*next); !st) {
            undo(*next);
            return st.error();
        }
    // Calls from processes go to this generation's exports (a replaced exporter's new code).
    if (running && s_.calls) {
        auto rebound = s_.calls->rebind(spec, runtime::functionExports());
        if (!rebound) {
            undo(*next);
            return Error{rebound.error().message, protocol::kRestartRequired};
        }
        next->calls = std::move(*rebound);
    }
    dispatch::CallServer *calls = next->calls ? next->calls.get() : s_.calls;

    // New process modules: a free control slot each, spawned and awaited until ready.
    std::vector<bool> slot_used(s_.control ? s_.control->slotCount() : 0, false);
    if (running)
        for (const Member &member : running->members)
            if (member.slot >= 0) slot_used[static_cast<std::size_t>(member.slot)] = true;
    bool any_new_process = false;
    const std::vector<dispatch::ExecutorOptions> threads = dispatch::executorsOf(spec, s_.dispatcher);
    for (const config::ModuleSpec &m : spec.modules) {
        Member &member = next->members[static_cast<std::size_t>(m.index)];
        if (member.kept || m.type != config::ModuleType::Process) continue;
        auto free = std::find(slot_used.begin(), slot_used.end(), false);
        if (free == slot_used.end()) {
            undo(*next);
            return errorAbout(m, "no free control slot (irpd has " + std::to_string(slot_used.size()) +
                                     "; the running set's processes keep theirs until the swap)");
        }
        auto sha = hosts::sha256File(m.path);
        if (!sha) {
            undo(*next);
            return errorAbout(m, sha.error().message);
        }
        member.sha256 = *sha;
        *free = true;
        member.slot = static_cast<int>(free - slot_used.begin());
        hosts::ProcessLaunch launch;
        launch.spec = m;
        launch.slot = static_cast<uint32_t>(member.slot);
        launch.control_shm = s_.control->name();
        launch.variables_shm = s_.vars ? s_.vars->name() : "";
        if (s_.alarms) {
            launch.alarms_shm = s_.alarms->name();
            launch.alarm_source = member.alarm_source;
        }
        if (m.operation != config::OperationType::NonReal)
            for (const dispatch::ExecutorOptions &e : threads)
                if (e.name == m.executor) {  // one below its executor, on its CPU
                    launch.rt_priority = s_.dispatcher.realtime ? std::max(1, e.rt_priority - 1) : 0;
                    launch.cpu = e.cpu;
                }
        if (Status st = s_.supervisor->start(launch); !st) {
            member.slot = -1;
            undo(*next);
            return st.error();
        }
        any_new_process = true;
    }
    if (any_new_process)
        if (Status st = s_.supervisor->waitReady(s_.ready_timeout_ns); !st) {
            undo(*next);
            return st.error();
        }

    // The executors' tables; kept modules' tasks carry their predecessors' state at the swap.
    std::vector<dispatch::ModuleBinding> bindings;
    for (const config::ModuleSpec &m : spec.modules) {
        Member &member = next->members[static_cast<std::size_t>(m.index)];
        dispatch::ModuleBinding b;
        b.stats = &s_.stats->record(member.record);
        if (member.thread) {
            b.run = member.thread->runFunction();
            b.condition = member.thread->table().condition;
            if (s_.alarms) b.alarm_source = member.alarm_source;
            b.fault_note = &member.thread->faultNote();
        }
        if (member.slot >= 0 && m.operation != config::OperationType::NonReal)
            b.process = &s_.control->slot(static_cast<uint32_t>(member.slot));
        if (calls) {
            b.owner = calls->ownerId(m.name);
            if (calls->serves(b.owner)) b.calls = calls;
        }
        b.disabled = next->disabled.count(m.name) > 0;
        bindings.push_back(b);
    }
    next->tables = dispatch::buildTables(spec, next->schedule, bindings);
    // Converted variables: the last executor to switch converts them (no module of the old set runs
    // any more); the new modules skip their runs until it did (docs/hot-reload.md "Converted variables").
    if (!next->conversions.converted.empty() && s_.vars) {
        next->conversion_data = s_.vars->data();
        next->gate = std::make_unique<dispatch::SwapGate>();
        next->gate->context = next;
        next->gate->work = [](void *g) noexcept {
            const auto &gen = *static_cast<const Generation *>(g);
            variables::converted(gen.conversions.converted, gen.conversion_data);
        };
        for (dispatch::Table &t : next->tables->executors) t.gate = next->gate.get();
        for (const config::ModuleSpec &m : spec.modules)
            if (dispatch::Task *task = next->tables->by_module[static_cast<std::size_t>(m.index)];
                task && !next->members[static_cast<std::size_t>(m.index)].kept)
                task->config.gate = next->gate.get();
    }
    if (running)
        for (const config::ModuleSpec &m : spec.modules) {
            dispatch::Task *task = next->tables->by_module[static_cast<std::size_t>(m.index)];
            const int old = running->find(m.name);
            if (!task || old < 0 || !next->members[static_cast<std::size_t>(m.index)].kept) continue;
            const dispatch::Task *before = running->tables->by_module[static_cast<std::size_t>(old)];
            // Carried only on the same executor: another executor's thread still writes it until the swap.
            if (before && m.executor == running->set.modules[static_cast<std::size_t>(old)].executor)
                task->config.predecessor = before;
            task->config.clear_fault = !task->config.disabled && running->disabled.count(m.name) > 0;
        }
    // Threads for executors the set adds or changes: started and parked until the swap.
    if (dispatcher_)
        if (Status st = dispatcher_->prepare(spec, *next->tables); !st) {
            undo(*next);
            return st.error();
        }
    return Ok{};
}

// Undoes a prepare that failed: the new modules and processes go, their records are freed.
void Reloader::undo(Generation &partial) {
    std::vector<uint32_t> slots;
    for (Member &member : partial.members) {
        if (member.kept) continue;
        if (member.slot >= 0) slots.push_back(static_cast<uint32_t>(member.slot));
        if (member.thread) {
            (void)member.thread->stop();
            member.thread.reset();
        }
        if (member.record >= s_.executors && s_.stats->record(member.record).kind == stats::RecordKind::Module)
            s_.stats->release(member.record);
        member.record = 0;
    }
    if (!slots.empty()) s_.supervisor->stop(slots, 2'000'000'000);
    if (s_.alarms) undoAlarmSources(*s_.alarms, partial, current().get());
    if (partial.published && partial.previous_layout) {
        (void)s_.vars->publish(*partial.previous_layout);  // it fitted before
        partial.published = false;
    }
    if (dispatcher_) dispatcher_->retire();  // executor threads started for it
}

void Reloader::adopt(std::unique_ptr<Generation> first, dispatch::Dispatcher &dispatcher) {
    dispatcher_ = &dispatcher;
    // The executors run already: a module that threw in its first runs was set Disabled by its
    // executor, which stays (only a record still Loaded is set).
    for (const config::ModuleSpec &m : first->set.modules) {
        auto expected = static_cast<uint32_t>(stats::ModuleState::Loaded);
        s_.stats->record(first->members[static_cast<std::size_t>(m.index)].record)
            .state.compare_exchange_strong(expected, static_cast<uint32_t>(first->disabled.count(m.name)
                                                                               ? stats::ModuleState::Disabled
                                                                               : stats::ModuleState::Running));
    }
    std::lock_guard lock(mutex_);
    current_ = std::shared_ptr<Generation>(std::move(first));
}

std::shared_ptr<const Generation> Reloader::current() const {
    std::lock_guard lock(mutex_);
    return current_;
}

// A set stopped by a fault (<on_overrun>stop</on_overrun>, docs/faults.md) stays stopped: its
// outputs were driven to safe values and the faulty module may still be stuck in run().
static Status refuseWhenHalted(const dispatch::Dispatcher *dispatcher) {
    if (dispatcher && dispatcher->isHalted())
        return Error{"the set was stopped by a fault (see the events and `status`): restart irpd to run a set again"};
    return Ok{};
}

Result<json> Reloader::load(const std::filesystem::path &xml, const std::string &set_id) {
    if (Status s = refuseWhenHalted(dispatcher_); !s) return s.error();
    const int64_t requested = now();
    auto set = config::parseModuleXml(xml);
    if (!set) {
        s_.events->add("swap_failed", "", set.error().message);
        return set.error();
    }
    resolveLayout(*set);
    const auto running = current();
    std::set<std::string> disabled = running->disabled;
    if (s_.left_out) disabled.merge(s_.left_out(*set));
    auto next = prepare(std::move(*set), running.get(), std::move(disabled), set_id);
    if (!next) {
        s_.events->add("swap_failed", "", next.error().message);
        return next.error();
    }
    return swap(std::move(*next), requested);
}

Result<json> Reloader::change(const Change &change) {
    auto answer = this->change(std::vector<Change>{change}, false);
    if (!answer) return answer.error();
    return (*answer)["report"];
}

namespace {

// The changes' warnings: what an operator may not have meant (docs/control-protocol.md, `change`).
std::vector<std::string> changeWarnings(const Generation &before, const Generation &after, const Estimate &estimate) {
    std::vector<std::string> warnings;
    if (after.schedule.basic_ns != before.schedule.basic_ns)
        warnings.push_back("the basic period (GCD of the periods) changes from " +
                           schedule::humanDuration(before.schedule.basic_ns) + " to " +
                           schedule::humanDuration(after.schedule.basic_ns) + ": every slot of the table moves");
    if (after.schedule.macro_ns != before.schedule.macro_ns)
        warnings.push_back("the macro period (LCM of the periods) changes from " +
                           schedule::humanDuration(before.schedule.macro_ns) + " to " +
                           schedule::humanDuration(after.schedule.macro_ns) + " (" +
                           std::to_string(after.schedule.slots.size()) + " slots)");
    // Modules of one executor with one priority run in file order; only pairs the changes made are named.
    auto sharing = [](const Generation &g) {
        std::set<std::pair<std::string, std::string>> pairs;
        for (const config::ModuleSpec &a : g.set.modules)
            for (const config::ModuleSpec &b : g.set.modules)
                if (a.index < b.index && a.operation != config::OperationType::NonReal &&
                    b.operation != config::OperationType::NonReal && a.executor == b.executor &&
                    a.priority == b.priority && !g.disabled.count(a.name) && !g.disabled.count(b.name))
                    pairs.emplace(a.name, b.name);
        return pairs;
    };
    const auto had = sharing(before);
    for (const auto &[a, b] : sharing(after)) {
        if (had.count({a, b})) continue;
        const config::ModuleSpec &m = after.set.modules[static_cast<std::size_t>(after.find(a))];
        warnings.push_back("modules '" + a + "' and '" + b + "' both have priority " + std::to_string(m.priority) +
                           " on executor '" + m.executor + "': they run in module.xml order");
    }
    for (const auto &[executor, busy] : estimate.busy)
        if (busy > protocol::kUtilizationWarning) {
            std::ostringstream text;
            text.precision(3);
            text << "executor '" << executor << "' would be " << busy * 100 << " % busy (above "
                 << protocol::kUtilizationWarning * 100
                 << " %): little room is left for jitter and for the non-real modules";
            warnings.push_back(text.str());
        }
    for (const config::ModuleSpec &m : after.set.modules)
        if (!after.members[static_cast<std::size_t>(m.index)].kept)
            warnings.push_back("module '" + m.name + "': its file changed since it was loaded (" + m.path.string() +
                               "), so this loads it anew: initialize() and start() again, its state and figures lost");
    return warnings;
}

}  // namespace

Result<json> Reloader::change(const std::vector<Change> &changes, bool dry_run) {
    if (Status s = refuseWhenHalted(dispatcher_); !s) return s.error();
    const int64_t requested = now();
    const auto running = current();
    config::SetSpec set = running->set;
    std::set<std::string> disabled = running->disabled, seen;
    std::string names;
    if (changes.empty())
        return Error{"'changes' is empty; give at least one {module, period_ns?, priority?, enabled?}"};
    for (const Change &change : changes) {
        const int index = running->find(change.module);
        if (index < 0) {
            std::string known;
            for (const auto &m : set.modules) known += (known.empty() ? "" : ", ") + m.name;
            return Error{"no module '" + change.module + "' in the running set (its modules: " + known + ")",
                         protocol::kNotFound};
        }
        if (!seen.insert(change.module).second)
            return Error{"module '" + change.module + "' is changed twice; give each module once, with all its values"};
        names += (names.empty() ? "" : ", ") + change.module;
        config::ModuleSpec &m = set.modules[static_cast<std::size_t>(index)];
        if (change.period_ns) {
            if (m.operation != config::OperationType::Periodic)
                return Error{"module '" + m.name + "' is " + config::toString(m.operation) +
                             ": only periodic modules have a period"};
            if (*change.period_ns <= 0) return Error{"period_ns must be a positive number of nanoseconds"};
            if (m.deadline_ns == m.period_ns) m.deadline_ns = *change.period_ns;
            m.period_ns = *change.period_ns;
            if (m.budget_ns > m.period_ns || m.deadline_ns > m.period_ns)
                return Error{"module '" + m.name + "': the period " + std::to_string(m.period_ns) +
                             " ns is shorter than its " +
                             (m.budget_ns > m.period_ns ? "<budget> " + std::to_string(m.budget_ns)
                                                        : "<deadline> " + std::to_string(m.deadline_ns)) +
                             " ns"};
        }
        if (change.priority) m.priority = *change.priority;
        if (change.enabled) {
            if (*change.enabled)
                disabled.erase(m.name);
            else
                disabled.insert(m.name);
        }
    }
    const std::string failed_module = changes.size() == 1 ? names : "";
    const std::string failed_prefix = changes.size() == 1 ? "" : "modules " + names + ": ";

    Estimate estimate;
    auto next = plan(std::move(set), running.get(), std::move(disabled), running->set_id, &estimate);
    if (!next) {
        if (!dry_run) s_.events->add("swap_failed", failed_module, failed_prefix + next.error().message);
        return next.error();
    }
    json utilization = json::object();
    for (const auto &[executor, busy] : estimate.busy) utilization[executor] = busy;
    json answer{{"dry_run", dry_run},
                {"before", scheduleJson(*running)},
                {"schedule", scheduleJson(**next)},
                {"utilization", utilization},
                {"warnings", changeWarnings(*running, **next, estimate)},
                {"report", nullptr}};
    if (dry_run) return answer;  // planned only: nothing was loaded, nothing to undo

    if (Status st = realize(**next, running.get()); !st) {
        s_.events->add("swap_failed", failed_module, failed_prefix + st.error().message);
        return st.error();
    }
    // A fault-disabled module comes back with enable: its new task does not inherit the disable.
    for (const Change &change : changes)
        if (change.enabled && *change.enabled)
            if (dispatch::Task *task =
                    (*next)->tables->by_module[static_cast<std::size_t>(running->find(change.module))])
                task->config.clear_fault = true;
    auto report = swap(std::move(*next), requested);
    if (!report) return report.error();
    answer["report"] = std::move(*report);
    if (s_.forgive)
        for (const Change &change : changes)
            if (change.enabled && *change.enabled) s_.forgive(change.module);
    return answer;
}

Result<json> Reloader::swap(std::unique_ptr<Generation> next, int64_t requested_ns) {
    const auto running = current();
    // Record metadata of kept modules (their period or priority may have changed).
    for (const config::ModuleSpec &m : next->set.modules) {
        stats::TimingRecord &r = s_.stats->record(next->members[static_cast<std::size_t>(m.index)].record);
        r.period_ns = m.period_ns;
        r.priority = m.priority;
        r.budget_ns = m.budget_ns;
        std::snprintf(r.executor, sizeof r.executor, "%s", m.executor.c_str());  // a kept module may move
    }
    // Periods lost by the dispatchers of both generations (arriving and leaving executors too).
    std::set<std::size_t> dispatchers(running->tables->records.begin(), running->tables->records.end());
    dispatchers.insert(next->tables->records.begin(), next->tables->records.end());
    auto lost = [&] {
        uint64_t n = 0;
        for (std::size_t e : dispatchers) n += s_.stats->record(e).missed.load() + s_.stats->record(e).skipped.load();
        return n;
    };
    const uint64_t lost_before = lost();
    const int64_t lead = std::max<int64_t>(2'000'000, 2 * running->schedule.basic_ns);
    const int64_t at = dispatcher_->boundaryAfter(now() + lead);
    // Converted variables: their new places are held (locked, sequence odd) from before the offer, so
    // that nobody else writes them, until every executor switched; the last one to switch converted
    // them (the tables' gate).
    const std::vector<variables::Conversion> &converted = next->conversions.converted;
    if (s_.vars) variables::hold(converted);
    dispatcher_->offer(*next->tables, at);
    std::optional<std::vector<dispatch::Switch>> switched;
    const int64_t give_up = now() + s_.swap_timeout_ns + (at - now());
    while (!(switched = dispatcher_->switched())) {
        if (now() > give_up && dispatcher_->withdraw()) {
            if (s_.vars) variables::release(converted, false);
            undo(*next);
            const std::string message = "the executors did not reach the swap slot within " +
                                        std::to_string(s_.swap_timeout_ns / 1'000'000) +
                                        " ms (a module stuck in run()?); the running set is unchanged";
            s_.events->add("swap_failed", "", message);
            return Error{message};
        }
        // Holding converted variables, look often: a new module's write of one waits for the lock.
        std::this_thread::sleep_for(std::chrono::microseconds(converted.empty() ? 200 : 20));
    }
    if (s_.vars) variables::release(converted, true);
    const int64_t swapped_ns = now();
    // One new macro period (at most 2 s) to see whether the new table's first slots were on time.
    const uint64_t cycles_then = s_.stats->header()->cycles.load();
    const uint64_t settle = static_cast<uint64_t>(next->schedule.macro_ns / next->schedule.basic_ns) + 1;
    const int64_t settle_until = now() + 2'000'000'000;
    while (s_.stats->header()->cycles.load() < cycles_then + settle && now() < settle_until &&
           s_.stats->header()->running.load())
        std::this_thread::sleep_for(std::chrono::microseconds(500));
    const uint64_t missed = lost() - lost_before;
    dispatcher_->retire();  // the threads of executors the new set does not have

    const auto [kept, started, stopped, replaced] = fatesOf(*next, running.get());
    retire(*running, *next);
    if (s_.alarms) settleAlarmSources(*s_.alarms, *next, *running);  // after retire stopped the old processes
    for (const config::ModuleSpec &m : next->set.modules)
        s_.stats->record(next->members[static_cast<std::size_t>(m.index)].record)
            .state.store(static_cast<uint32_t>(next->disabled.count(m.name) ? stats::ModuleState::Disabled
                                                                            : stats::ModuleState::Running));
    std::snprintf(s_.stats->header()->set_path, sizeof s_.stats->header()->set_path, "%s", next->set.xml_path.c_str());
    s_.stats->header()->basic_ns = next->schedule.basic_ns;
    if (s_.trace) s_.trace->setBasicPeriod(next->schedule.basic_ns);
    s_.stats->header()->macro_ns = next->schedule.macro_ns;

    json report{{"set", next->set.xml_path.string()},
                {"set_id", next->set_id.empty() ? json(nullptr) : json(next->set_id)},
                {"generation", next->number},
                {"swap_cycle", switched->front().cycle},
                {"swap_at_ns", at},
                {"basic_period_ns", next->schedule.basic_ns},
                {"macro_period_ns", next->schedule.macro_ns},
                {"kept", names(kept)},
                {"started", names(started)},
                {"stopped", names(stopped)},
                {"replaced", names(replaced)},
                {"missed_periods", missed},
                {"variables", variablesJson(*next)},
                {"request_to_swap_ns", swapped_ns - requested_ns},
                {"total_ns", now() - requested_ns}};
    std::ostringstream text;
    text << "generation " << next->number << " (" << next->set.xml_path.string() << ") took over in slot "
         << switched->front().cycle << ": " << kept.size() << " kept, " << started.size() << " started, "
         << stopped.size() << " stopped (" << replaced.size() << " of them replaced), " << missed << " periods missed";
    if (next->published)
        text << "; shared variables " << shown(next->variables.added, next->variables.internal).size() << " added, "
             << shown(next->variables.removed, next->variables.internal).size() << " removed, "
             << next->variables.moved.size() << " moved, " << next->conversions.converted.size()
             << " converted (layout " << next->layout->hash.substr(0, 12) << "…)";
    s_.events->add("swap", "", text.str());
    if (next->calls) s_.calls = next->calls.get();
    {
        std::lock_guard lock(mutex_);
        current_ = std::shared_ptr<Generation>(std::move(next));
    }
    if (s_.swapped) s_.swapped(*current_);
    return report;
}

// After the swap: what the new generation does not run any more is stopped and unloaded.
void Reloader::retire(const Generation &old, const Generation &next) {
    std::vector<uint32_t> slots;
    std::vector<std::filesystem::path> images;
    for (std::size_t i = old.members.size(); i-- > 0;) {  // reverse file order
        const config::ModuleSpec &m = old.set.modules[i];
        const Member &member = old.members[i];
        const int n = next.find(m.name);
        if (n >= 0 && next.members[static_cast<std::size_t>(n)].kept) continue;
        if (member.thread)
            if (Status st = member.thread->stop(); !st) s_.events->add("fault", m.name, st.error().message);
        if (member.slot >= 0) slots.push_back(static_cast<uint32_t>(member.slot));
        s_.stats->release(member.record);
    }
    if (!slots.empty()) s_.supervisor->stop(slots, 2'000'000'000);
    // The libraries are unloaded when the old generation's last reference goes (after this call).
    for (const config::ModuleSpec &m : next.set.modules) {
        const Member &member = next.members[static_cast<std::size_t>(m.index)];
        if (member.thread) images.push_back(member.sha256 + "-" + m.path.filename().string());
    }
    s_.cache->prune(images);
}

std::vector<std::string> Reloader::stopAll() {
    std::vector<std::string> errors;
    const auto running = current();
    if (!running) return errors;
    for (const Member &member : running->members)
        if (member.thread)
            if (Status st = member.thread->stop(); !st) errors.push_back(st.error().message);
    for (const config::ModuleSpec &m : running->set.modules)
        s_.stats->record(running->members[static_cast<std::size_t>(m.index)].record)
            .state.store(static_cast<uint32_t>(stats::ModuleState::Stopped));
    return errors;
}

}  // namespace irp::reload
