// commands.cpp -- what each control command does.
#include "irpd/commands.hpp"

#include "osal/clock.hpp"
#include "protocol/arguments.hpp"
#include "protocol/errors.hpp"
#include "sdk/alarm_rules.hpp"
#include "sdk/runtime.hpp"
#include "stats/summary.hpp"
#include "variables/variable_write.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <limits>

namespace irp::daemon {
namespace {

using json = nlohmann::ordered_json;

// The arguments decodeCommand takes, after protocol::checkArguments has checked them.
std::string textOf(const nlohmann::json &request, const char *name) {
    auto it = request.find(name);
    return it == request.end() ? std::string() : it->get<std::string>();
}

reload::Change changeOf(const nlohmann::json &entry) {
    reload::Change change;
    change.module = entry.at("module").get<std::string>();
    if (entry.contains("period_ns")) change.period_ns = entry["period_ns"].get<int64_t>();
    if (entry.contains("priority")) change.priority = static_cast<int>(entry["priority"].get<int64_t>());
    if (entry.contains("enabled")) change.enabled = entry["enabled"].get<bool>();
    return change;
}

// status: the last crash irpd recorded, and the modules left out after one (supervise/crash_record.hpp).
json lastCrash(const CommandContext &c) {
    if (!c.crash) return nullptr;
    const auto last = c.crash->last();
    return last ? last->toJson() : json(nullptr);
}

json leftOut(const CommandContext &c) {
    json list = json::array();
    if (c.crash)
        for (const auto &[module, set] : c.crash->allExcluded()) list.push_back({{"module", module}, {"set", set}});
    return list;
}

// The stop's share of a restart's downtime: the dispatchers end their slot (two of the longest basic
// period) and the processes end: a periodic or sporadic one at its next waitPeriod() (20 ms
// allowed); a non-real one gets SIGTERM at once in a restart (20 ms allowed as well).
int64_t stopEstimateNs(const reload::Generation &g) {
    int64_t longest = g.schedule.basic_ns;
    for (const auto &table : g.tables->executors) longest = std::max(longest, table.basic_ns);
    bool processes = false;
    for (const config::ModuleSpec &m : g.set.modules) processes |= m.type == config::ModuleType::Process;
    return 2 * longest + (processes ? 20'000'000 : 0);
}

// `restart`: the set checked as `check` does (a refusal other than restart_required refuses it now,
// with that error, and nothing stops), then handed to the main thread, which stops and executes
// irpd again at its next tick.  Answered at once.
Result<json> askRestart(const CommandContext &c, const reload::Generation &g, const Command &command) {
    if (!c.restarts) return Error{"this irpd cannot restart itself"};
    const json checked = c.reloader->check(command.config);
    if (!checked.value("valid", false)) {
        // One refusal: every sentence, and the place of the first.
        Error refused;
        for (const auto &e : checked["errors"])
            refused.message += (refused.message.empty() ? "" : "; ") + e.get<std::string>();
        if (!checked["problems"].empty()) refused.place = protocol::placeFrom(checked["problems"][0]);
        return refused;
    }
    RestartPlan plan;
    plan.target = {std::filesystem::absolute(command.config).string(), command.set_id, ""};
    plan.origin = {std::filesystem::absolute(g.set.xml_path).string(), g.set_id, c.options->layout};
    plan.requested_ns = osal::monotonicNow();
    plan.expected_downtime_ns = c.restarts->expectedDowntimeNs(stopEstimateNs(g));
    if (Status st = c.restarts->request(plan); !st) return st.error();
    auto id = [](const std::string &s) { return s.empty() ? json(nullptr) : json(s); };
    return json{{"restarting", true},
                {"pid", getpid()},
                {"from_set_id", id(plan.origin.set_id)},
                {"set_id", id(plan.target.set_id)},
                {"expected_downtime_ns", plan.expected_downtime_ns},
                {"requested_ns", plan.requested_ns}};
}

json moduleEntry(const reload::Generation &g, const config::ModuleSpec &m, const stats::StatsSegment &stats) {
    const reload::Member &member = g.members[static_cast<std::size_t>(m.index)];
    json entry = stats::toJson(stats.record(member.record));
    entry["moduletype"] = config::toString(m.type);
    entry["operationtype"] = config::toString(m.operation);
    entry["priority"] = m.priority;
    entry["deadline_ns"] = m.deadline_ns;
    entry["budget_ns"] = m.budget_ns;
    entry["enabled"] = g.disabled.count(m.name) == 0;
    entry["file"] = m.path.string();
    entry["sha256"] = member.sha256;
    json properties = json::object();
    for (const auto &[k, v] : m.properties) properties[k] = v;
    entry["properties"] = properties;
    return entry;
}

// alarms: irpd's source, then every module's by source, with what it declared and its counters.
json alarmSources(const alarms::AlarmSegment &segment, const reload::Generation &g, bool retain) {
    auto source = [&](uint32_t index, json declared) {
        const alarms::SourceView v = segment.view(index);
        return json{{"source", v.source},
                    {"module", v.name},
                    {"generation", v.generation},
                    {"declared", std::move(declared)},
                    {"active", v.active},
                    {"recorded", v.recorded},
                    {"rate_dropped", v.rate_dropped},
                    {"undeclared", v.undeclared},
                    {"bad_ids", v.bad_ids},
                    {"truncated", v.truncated}};
    };
    json own = json::array();  // irpd's: the retain store's (docs/retain.md)
    if (retain)
        for (const retain::Declared &d : retain::kAlarms)
            own.push_back({{"id", d.id}, {"severity", d.severity}, {"text", d.text}, {"origin", "irpd"}});
    std::vector<std::pair<uint32_t, json>> sources{{alarms::kIrpdSource, source(alarms::kIrpdSource, std::move(own))}};
    for (const config::ModuleSpec &m : g.set.modules) {
        const reload::Member &member = g.members[static_cast<std::size_t>(m.index)];
        std::vector<runtime::AlarmDeclaration> list;
        if (member.thread)
            list = runtime::alarmsOf(member.thread->instance());
        else
            for (const config::AlarmSpec &a : m.alarms) list.push_back({a.id, a.severity, a.text, false});
        json declared = json::array();
        for (const runtime::AlarmDeclaration &d : list)
            declared.push_back({{"id", d.id},
                                {"severity", alarm_rules::severityName(d.severity)},
                                {"text", d.text},
                                {"origin", d.from_code ? "code" : "module.xml"}});
        sources.emplace_back(member.alarm_source, source(member.alarm_source, std::move(declared)));
    }
    std::sort(sources.begin(), sources.end(), [](const auto &a, const auto &b) { return a.first < b.first; });
    json list = json::array();
    for (auto &[index, entry] : sources) list.push_back(std::move(entry));
    return json{{"segment", segment.name()}, {"rate_limit", segment.rateLimit()}, {"sources", std::move(list)}};
}

}  // namespace

Result<Command> decodeCommand(const std::string &cmd, const nlohmann::json &request) {
    auto spec = protocol::findCommand(cmd);
    if (!spec) return spec.error();
    if (Status checked = protocol::checkArguments(**spec, request); !checked) return checked.error();
    Command command;
    using Kind = Command::Kind;
    command.kind = (*spec)->cmd;
    switch (command.kind) {
    case Kind::Histograms: command.name = textOf(request, "name"); break;
    case Kind::Events:
        command.since = request.value("since", uint64_t{0});
        if (request.contains("limit"))
            command.limit = static_cast<std::size_t>(
                std::min<int64_t>(request["limit"].get<int64_t>(), protocol::kEventLogCapacity));
        break;
    case Kind::Check:
    case Kind::Load:
    case Kind::Restart:
        command.config = textOf(request, "config");
        command.set_id = textOf(request, "set_id");
        break;
    case Kind::Write:
    case Kind::Force:
        command.path = textOf(request, "path");
        command.value = request["value"];
        command.by = textOf(request, "by");
        break;
    case Kind::Unforce:
        command.path = textOf(request, "path");
        command.restore = request.value("restore", false);
        break;
    case Kind::SetPeriod:
    case Kind::SetPriority:
    case Kind::Enable:
    case Kind::Disable: {
        // Only the value the command names: other members of the request are not its arguments.
        reload::Change change;
        change.module = textOf(request, "module");
        if (command.kind == Kind::SetPeriod)
            change.period_ns = request["period_ns"].get<int64_t>();
        else if (command.kind == Kind::SetPriority)
            change.priority = static_cast<int>(request["priority"].get<int64_t>());
        else
            change.enabled = command.kind == Kind::Enable;
        command.changes.push_back(std::move(change));
        break;
    }
    case Kind::Change:
        for (const nlohmann::json &entry : request["changes"]) command.changes.push_back(changeOf(entry));
        command.dry_run = request.value("dry_run", false);
        break;
    case Kind::Status:
    case Kind::Schedule:
    case Kind::Modules:
    case Kind::Stats:
    case Kind::Alarms:
    case Kind::ClearCrash:
    case Kind::Forces:
    case Kind::Trace: break;
    }
    return command;
}

// The running layout.json, parsed again only when an online change published another one.
// Used by the control thread alone.
class LayoutCache {
public:
    const nlohmann::json &of(const variables::VariableSegment &vars) {
        std::string hash, text;
        segment::copyLayout(vars.header(), hash, text);
        if (hash != hash_) {
            doc_ = nlohmann::json::parse(text, nullptr, false);
            hash_ = hash;
        }
        return doc_;
    }

private:
    std::string hash_;
    nlohmann::json doc_;
};

control::Handler commandHandler(const CommandContext &c) {
    auto layouts = std::make_shared<LayoutCache>();
    return [c, layouts](const std::string &cmd, const nlohmann::json &request) -> Result<json> {
        const auto g = c.reloader->current();
        // The socket opens before the dispatchers start: until then there is no running generation.
        if (!g) return Error{"irpd is starting (the set is not dispatched yet); try again in a moment"};
        auto decoded = decodeCommand(cmd, request);
        if (!decoded) return decoded.error();
        const Command &command = *decoded;
        const stats::Header *h = c.stats->header();
        const std::vector<std::size_t> &executors = g->tables->records;  // the dispatchers' records, main first
        auto onMain = [&c](std::function<MainQueue::Answer()> job) {
            return c.queue->call(std::move(job), std::chrono::milliseconds(protocol::kMainThreadWaitMs));
        };
        switch (command.kind) {
        case Command::Kind::Status: {
            const stats::TimingRecord &d = c.stats->record(0);
            const std::string fault = c.stopped_by ? c.stopped_by() : std::string();
            const int64_t started = h->started_ns.load(), now = osal::monotonicNow();
            return json{{"forces", c.forcing ? c.forcing->count() : 0},
                        {"set", g->set.xml_path.string()},
                        {"set_id", g->set_id.empty() ? json(nullptr) : json(g->set_id)},
                        {"generation", g->number},
                        {"running", h->running.load() == 1},
                        {"realtime", h->realtime.load() == 1},
                        {"pid", h->pid},
                        {"basic_period_ns", g->schedule.basic_ns},
                        {"macro_period_ns", g->schedule.macro_ns},
                        {"min_basic_period_ns", c.reloader->limits().min_basic_ns},
                        {"uptime_ns", started && now > started ? now - started : 0},
                        {"cycles", h->cycles.load()},
                        {"modules", g->set.modules.size()},
                        {"overruns", d.overruns.load()},
                        {"missed", d.missed.load()},
                        {"skipped", d.skipped.load()},
                        {"caught_up", d.caught_up.load()},
                        {"stats_dropped", stats::statsDropped(&d, g->tables->records)},
                        {"events", c.events->last()},
                        {"stopped_by_fault", fault.empty() ? json(nullptr) : json(fault)},
                        {"last_crash", lastCrash(c)},
                        {"left_out_after_crash", leftOut(c)},
                        {"last_restart", c.restarts ? c.restarts->lastRestart() : json(nullptr)},
                        {"retain", c.retain ? json(c.retain->status()) : json(nullptr)},
                        {"shared_memory",
                         {{"stats", c.stats->name()},
                          {"variables", c.variables_shm.empty() ? json(nullptr) : json(c.variables_shm)},
                          {"trace", c.trace->describe().value("shm", "")},
                          {"alarms", c.alarms ? c.alarms->name() : ""}}}};
        }
        case Command::Kind::Schedule: return reload::scheduleJson(*g);
        case Command::Kind::Modules: {
            json list = json::array();
            for (const config::ModuleSpec &m : g->set.modules) list.push_back(moduleEntry(*g, m, *c.stats));
            return list;
        }
        case Command::Kind::Stats: {
            json executors_json = json::array(), modules = json::array();
            for (std::size_t i : executors) executors_json.push_back(stats::toJson(c.stats->record(i)));
            for (const config::ModuleSpec &m : g->set.modules)
                modules.push_back(stats::toJson(c.stats->record(g->members[static_cast<std::size_t>(m.index)].record)));
            return json{{"cycles", h->cycles.load()}, {"executors", executors_json}, {"modules", modules}};
        }
        case Command::Kind::Alarms:
            if (!c.alarms) return Error{"this irpd has no alarm segment"};
            return alarmSources(*c.alarms, *g, c.retain != nullptr);
        case Command::Kind::Histograms: {
            // Every dispatcher record, then every module's, or those named `name`.
            const std::string &name = command.name;
            json records = json::array();
            auto add = [&](const stats::TimingRecord &r) {
                if (name.empty() || name == r.name) records.push_back(stats::histogramsJson(r));
            };
            for (std::size_t i : executors) add(c.stats->record(i));
            for (const config::ModuleSpec &m : g->set.modules)
                add(c.stats->record(g->members[static_cast<std::size_t>(m.index)].record));
            if (records.empty()) {
                std::string known;
                for (std::size_t i : executors)
                    known += (known.empty() ? "" : ", ") + std::string(c.stats->record(i).name);
                for (const config::ModuleSpec &m : g->set.modules) known += ", " + m.name;
                return Error{"no dispatcher or module '" + name + "' in the running set (the records: " + known + ")",
                             protocol::kNotFound};
            }
            return json{
                {"cycles", h->cycles.load()}, {"time_ns", osal::monotonicNow()}, {"records", std::move(records)}};
        }
        case Command::Kind::Events: return c.events->since(command.since, command.limit);
        case Command::Kind::Check: {
            json checked = c.reloader->check(command.config);
            if (checked["restart"].is_object() && c.restarts)
                checked["restart"]["expected_downtime_ns"] = c.restarts->expectedDowntimeNs(stopEstimateNs(*g));
            return checked;
        }
        case Command::Kind::Restart: return askRestart(c, *g, command);
        case Command::Kind::Write:
            if (c.variables_shm.empty() || !c.vars) return Error{"the running set has no shared variables"};
            if (c.forcing)
                if (std::string why = c.forcing->refusal(command.path); !why.empty())
                    return Error{why, protocol::kForced};
            return variables::writeByPath(layouts->of(*c.vars), command.path, command.value);
        case Command::Kind::Force:
            if (!c.vars || !c.forcing) return Error{"the running set has no shared variables to force"};
            return c.forcing->force(layouts->of(*c.vars), command.path, command.value, command.by);
        case Command::Kind::Unforce:
            if (!c.forcing) return Error{"the running set has no shared variables to force"};
            return c.forcing->unforce(command.path, command.restore);
        case Command::Kind::Forces:
            if (!c.forcing) return json{{"forces", json::array()}, {"max_forces", protocol::kMaxForces}};
            return c.forcing->list();
        case Command::Kind::Load:
            return onMain(
                [r = c.reloader, path = command.config, set_id = command.set_id] { return r->load(path, set_id); });
        case Command::Kind::SetPeriod:
        case Command::Kind::SetPriority:
        case Command::Kind::Enable:
        case Command::Kind::Disable:
            // One change that answers its swap report.
            return onMain([r = c.reloader, change = command.changes.front()] { return r->change(change); });
        case Command::Kind::Change:
            return onMain([r = c.reloader, changes = command.changes, dry_run = command.dry_run] {
                return r->change(changes, dry_run);
            });
        case Command::Kind::Trace: return trace::handleTraceCommand(*c.trace, c.vars, request);
        case Command::Kind::ClearCrash: {
            if (!c.crash) return Error{"irpd keeps no crash records (no state folder; see --state-dir)"};
            json cleared = c.crash->clear();
            c.events->add("crash_cleared", "",
                          "crash record and left-out modules cleared; a module left out runs "
                          "again when enabled, or at the next start or load of its set");
            return cleared;
        }
        }
        return Error{"unknown command '" + cmd + "'"};
    };
}

}  // namespace irp::daemon
