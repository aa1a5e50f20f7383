// daemon.cpp -- what irpd does, in order:
//   1. parse module.xml and build the slot table (--print-schedule stops here);
//   2. create the stats block, the shared variables and the trace rings in shared memory; load,
//      initialize and start the modules; create the control segment of the process modules with
//      the table of shared functions they may call; start the processes;
//   3. lock memory and start the dispatcher threads (SCHED_FIFO, pinned);
//   4. the main thread becomes the non-RT side: it drains module output (irp::printf) and waits
//      for SIGINT/SIGTERM or the end of --duration;
//   5. stop the dispatchers, stop() every module, write --stats-json, unload, remove the shm.
#include "irpd/daemon.hpp"

#include "config/module_xml.hpp"
#include "control/control_server.hpp"
#include "dispatch/dispatcher.hpp"
#include "dispatch/function_calls.hpp"
#include "hosts/control_segment.hpp"
#include "hosts/module_set.hpp"
#include "hosts/process_supervisor.hpp"
#include "osal/clock.hpp"
#include "osal/rt.hpp"
#include "schedule/schedule.hpp"
#include "sdk/runtime.hpp"
#include "stats/stats_segment.hpp"
#include "stats/summary.hpp"
#include "trace/trace_rings.hpp"
#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"

#include <nlohmann/json.hpp>

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>

namespace irp::daemon {
namespace {

void say(const std::string &line) { std::cerr << "irpd: " << line << std::endl; }

int refuse(const std::string &message) {
    std::cerr << "irpd: error: " << message << std::endl;
    return kExitRefused;
}

void drainModuleOutput() {
    runtime::drainLog([](std::string_view line) {
        std::fwrite(line.data(), 1, line.size(), stdout);
        if (line.empty() || line.back() != '\n') std::fputc('\n', stdout);
    });
    std::fflush(stdout);
}

bool writeStats(const std::string &path, const config::SetSpec &set, const schedule::Schedule &schedule,
                const stats::StatsSegment &segment, const dispatch::Dispatcher &dispatcher, const Options &options,
                int64_t elapsed_ns) {
    using json = nlohmann::ordered_json;
    json executors = json::array(), modules = json::array();
    for (std::size_t i = 0; i < segment.recordCount(); ++i) {
        const stats::TimingRecord &r = segment.record(i);
        (r.kind == stats::RecordKind::Dispatcher ? executors : modules).push_back(stats::toJson(r));
    }
    json doc = {{"set", set.xml_path.string()},
                {"realtime", dispatcher.realtime()},
                {"overrun_policy", dispatch::toString(options.dispatcher.policy)},
                {"basic_period_ns", schedule.basic_ns},
                {"macro_period_ns", schedule.macro_ns},
                {"elapsed_ns", elapsed_ns},
                {"cycles", segment.header()->cycles.load()},
                {"log_lines_dropped", runtime::droppedLogLines()},
                {"dispatcher", executors.at(0)},
                {"executors", executors},
                {"modules", modules}};
    std::ofstream out(path);
    out << doc.dump(2) << "\n";
    return static_cast<bool>(out);
}

// Spawns every process module: periodic and sporadic ones at SCHED_FIFO one below their
// executor's dispatcher, on its CPU; non-real ones at SCHED_OTHER, unpinned.  Then waits until
// the RT ones called irp::initPeriodExe(), so that the first release is not missed.
Status startProcesses(hosts::ProcessSupervisor &supervisor, const std::vector<const config::ModuleSpec *> &processes,
                      hosts::ControlSegment *control, const std::string &variables_shm, const config::SetSpec &set,
                      const Options &options) {
    if (processes.empty()) return Ok{};
    for (std::size_t s = 0; s < processes.size(); ++s) {
        const config::ModuleSpec &m = *processes[s];
        hosts::ProcessLaunch launch;
        launch.spec = m;
        launch.slot = static_cast<uint32_t>(s);
        launch.control_shm = control->name();
        launch.variables_shm = variables_shm;
        if (m.operation != config::OperationType::NonReal) {
            int priority = options.dispatcher.rt_priority, cpu = options.dispatcher.cpu;
            for (const config::ExecutorSpec &e : set.executors)
                if (e.name == m.executor) {
                    priority = e.rt_priority ? e.rt_priority : priority - 1;
                    if (e.cpu >= 0) cpu = e.cpu;
                }
            launch.rt_priority = options.dispatcher.realtime ? std::max(1, priority - 1) : 0;
            launch.cpu = cpu >= 0 ? cpu : osal::lastAllowedCpu();
        }
        if (Status st = supervisor.start(launch); !st) return st;
    }
    return supervisor.waitReady(5'000'000'000);
}

// What the control thread may use once the main thread created it (null before).
struct Published {
    std::atomic<const variables::VariableSegment *> vars{nullptr};
    std::atomic<trace::TraceRings *> trace{nullptr};
};

// The control protocol's commands (docs/control-protocol.md).  Runs on the control thread: it
// reads the set and schedule (never changed while running) and the shared-memory stats block,
// and configures the trace rings (docs/trace-and-stream.md).
control::Handler controlHandler(const config::SetSpec &set, const schedule::Schedule &schedule,
                                const stats::StatsSegment &segment, std::size_t executors, const Options &options,
                                const Published &published) {
    using json = nlohmann::ordered_json;
    return [&set, &schedule, &segment, executors, &options, &published](const std::string &cmd,
                                                                        const nlohmann::json &request) -> Result<json> {
        const stats::Header *h = segment.header();
        if (cmd == "status") {
            const stats::TimingRecord &d = segment.record(0);
            const int64_t started = h->started_ns.load(), now = osal::monotonicNow();
            return json{{"set", set.xml_path.string()},
                        {"running", h->running.load() == 1},
                        {"realtime", h->realtime.load() == 1},
                        {"pid", h->pid},
                        {"basic_period_ns", schedule.basic_ns},
                        {"macro_period_ns", schedule.macro_ns},
                        {"uptime_ns", started && now > started ? now - started : 0},
                        {"cycles", h->cycles.load()},
                        {"modules", set.modules.size()},
                        {"overruns", d.overruns.load()},
                        {"missed", d.missed.load()},
                        {"skipped", d.skipped.load()},
                        {"caught_up", d.caught_up.load()},
                        {"shared_memory",
                         {{"stats", segment.name()},
                          {"variables", set.layout.empty() ? json(nullptr)
                                                           : json(variables::VariableSegment::shmName(options.instance))},
                          {"trace", trace::TraceRings::shmName(options.instance)}}}};
        }
        if (cmd == "schedule") return schedule::toJson(schedule, set);
        if (cmd == "modules") {
            json list = json::array();
            for (const config::ModuleSpec &m : set.modules) {
                json entry = stats::toJson(segment.record(executors + static_cast<std::size_t>(m.index)));
                entry["moduletype"] = config::toString(m.type);
                entry["operationtype"] = config::toString(m.operation);
                entry["deadline_ns"] = m.deadline_ns;
                entry["file"] = m.path.string();
                list.push_back(std::move(entry));
            }
            return list;
        }
        if (cmd == "stats") {
            json executors_json = json::array(), modules = json::array();
            for (std::size_t i = 0; i < segment.recordCount(); ++i) {
                const stats::TimingRecord &r = segment.record(i);
                (r.kind == stats::RecordKind::Dispatcher ? executors_json : modules).push_back(stats::toJson(r));
            }
            return json{{"cycles", h->cycles.load()}, {"executors", executors_json}, {"modules", modules}};
        }
        if (cmd == "trace") {
            trace::TraceRings *rings = published.trace.load();
            if (!rings) return Error{"irpd is starting: the trace rings do not exist yet"};
            return trace::handleTraceCommand(*rings, published.vars.load(), request);
        }
        for (const char *later : {"load", "set_period", "set_priority", "enable", "disable"})
            if (cmd == later)
                return Error{"command '" + cmd + "' is not available in protocol version " +
                             std::to_string(control::kProtocolVersion) + " of this irpd"};
        return Error{"unknown command '" + cmd + "'; the commands are status, schedule, modules, stats, trace"};
    };
}

} // namespace

int run(const Options &options) {
    // 1. the set and its schedule
    auto set = config::parseModuleXml(options.config);
    if (!set) return refuse(set.error().message);
    auto schedule = schedule::build(*set, options.limits);
    if (!schedule) return refuse(schedule.error().message);
    if (options.print_schedule) {
        if (options.json) std::cout << schedule::toJson(*schedule, *set).dump(2) << std::endl;
        else std::cout << schedule::formatText(*schedule, *set);
        return kExitOk;
    }

    // The set's shared-variable layout: --layout, else <layout>, else a layout.json beside
    // module.xml (the build puts it there).  Decided before any thread can read the set.
    if (!options.layout.empty()) set->layout = options.layout;
    const auto beside = set->xml_path.parent_path() / "layout.json";
    if (set->layout.empty() && std::filesystem::is_regular_file(beside)) set->layout = beside;

    // 2. stats block, modules
    const std::size_t executors = dispatch::Dispatcher::executorCount(*set);
    auto segment = stats::StatsSegment::create(options.instance, executors + set->modules.size());
    if (!segment) return std::cerr << "irpd: error: " << segment.error().message << std::endl, kExitFailure;
    stats::Header *header = segment->header();
    header->basic_ns = schedule->basic_ns;
    header->macro_ns = schedule->macro_ns;
    std::snprintf(header->set_path, sizeof header->set_path, "%s", set->xml_path.c_str());

    // Created below, published to the control thread once they exist; declared before the
    // control server, so that they outlive it.
    std::optional<variables::VariableSegment> vars;
    std::optional<trace::TraceRings> trace_rings;
    Published published;

    // The control socket, before anything starts: a path that cannot be served refuses the run.
    std::unique_ptr<control::ControlServer> control_server;
    if (!options.control_socket.empty()) {
        auto opened = control::ControlServer::open(options.control_socket,
                                                   controlHandler(*set, *schedule, *segment, executors, options, published));
        if (!opened) return std::cerr << "irpd: error: " << opened.error().message << std::endl, kExitFailure;
        control_server = std::move(*opened);
        say("control socket " + control_server->path());
    }

    // Shared variables: the segment exists before any module is loaded.
    if (!set->layout.empty()) {
        auto layout = variables::readLayout(set->layout);
        if (!layout) return refuse(layout.error().message);
        auto segment = variables::VariableSegment::create(options.instance, *layout);
        if (!segment) return std::cerr << "irpd: error: " << segment.error().message << std::endl, kExitFailure;
        vars = std::move(*segment);
        say("shared variables: " + std::to_string(layout->variables) + " variables, " +
            std::to_string(layout->data_size) + " bytes, layout " + vars->hash() + ", in /dev/shm" + vars->name());
        published.vars.store(&*vars);
    }

    // Trace rings: sampled by the main dispatcher after every slot; channels set by `trace`.
    // Created before memory is locked, every page touched: the RT thread never faults on them.
    {
        auto rings = trace::TraceRings::create(options.instance);
        if (!rings) return std::cerr << "irpd: error: " << rings.error().message << std::endl, kExitFailure;
        trace_rings.emplace(std::move(*rings));
        trace_rings->setBasicPeriod(schedule->basic_ns);
        published.trace.store(&*trace_rings);
    }

    auto modules = hosts::ModuleSet::load(*set, vars ? vars->hash() : nullptr);
    if (!modules) return refuse(modules.error().message);
    std::vector<dispatch::ModuleBinding> bindings;
    for (const config::ModuleSpec &m : set->modules) {
        const auto i = static_cast<std::size_t>(m.index);
        stats::TimingRecord &record = segment->describe(executors + i, stats::RecordKind::Module, m.name, m.executor,
                                                        m.period_ns, m.priority, m.budget_ns);
        hosts::ThreadModule *module = (*modules)->module(i);
        record.state.store(static_cast<uint32_t>(stats::ModuleState::Loaded));
        dispatch::ModuleBinding binding;
        binding.stats = &record;
        if (module) {
            binding.run = module->runFunction();
            binding.condition = module->table().condition;
        }
        bindings.push_back(binding);
    }
    if (Status s = (*modules)->initializeAll(); !s) return refuse(s.error().message);
    if (Status s = (*modules)->startAll(); !s) return refuse(s.error().message);

    // Process modules: a control slot each, spawned and watched by the supervisor; the control
    // segment also carries the table of shared functions they may call (every export is known
    // once every module started), served by the owners' executors (dispatch/function_calls.hpp).
    std::optional<hosts::ControlSegment> control;
    std::unique_ptr<dispatch::CallServer> calls;  // outlives the dispatcher (declared before it)
    hosts::ProcessSupervisor supervisor([](std::string_view line) {
        std::fwrite(line.data(), 1, line.size(), stdout);
        std::fputc('\n', stdout);
    });
    std::vector<const config::ModuleSpec *> processes;
    for (const config::ModuleSpec &m : set->modules)
        if (m.type == config::ModuleType::Process) processes.push_back(&m);
    if (!processes.empty()) {
        const std::vector<runtime::FunctionExport> exports = runtime::functionExports();
        auto created = hosts::ControlSegment::create(options.instance, static_cast<uint32_t>(processes.size()),
                                                     static_cast<uint32_t>(exports.size()));
        if (!created) {
            for (const std::string &e : (*modules)->stopAll()) say(e);
            return std::cerr << "irpd: error: " << created.error().message << std::endl, kExitFailure;
        }
        control = std::move(*created);
        for (std::size_t s = 0; s < processes.size(); ++s)
            if (processes[s]->operation != config::OperationType::NonReal)
                bindings[static_cast<std::size_t>(processes[s]->index)].process = &control->slot(static_cast<uint32_t>(s));
        std::vector<std::string> notes;
        calls = dispatch::CallServer::publish(*control, *set, exports, notes);
        for (const std::string &n : notes) say("note: " + n);
        for (const config::ModuleSpec &m : set->modules)
            if (calls->serves(m.index)) bindings[static_cast<std::size_t>(m.index)].calls = calls.get();
    }
    if (Status s = startProcesses(supervisor, processes, control ? &*control : nullptr, vars ? vars->name() : "", *set,
                                  options);
        !s) {
        supervisor.stopAll(1'000'000'000);
        for (const std::string &e : (*modules)->stopAll()) say(e);
        return refuse(s.error().message);
    }
    drainModuleOutput();

    // 3. dispatchers
    int dma_latency_fd = -1;  // held open while dispatching
    if (options.dispatcher.realtime) {
        if (Status s = osal::lockMemory(); !s) say("WARNING: " + s.error().message + "; page faults may add latency");
        dma_latency_fd = osal::holdCpuDmaLatencyZero();
        if (dma_latency_fd < 0) say("note: /dev/cpu_dma_latency not held at 0; CPU idle states may add wake-up latency");
    }
    dispatch::DispatcherOptions dispatcher_options = options.dispatcher;
    dispatcher_options.trace = &*trace_rings;
    dispatch::Dispatcher dispatcher(*set, *schedule, std::move(bindings), *segment, dispatcher_options,
                                    osal::monotonicClock());
    const int64_t duration_ns = static_cast<int64_t>(options.duration_s * 1e9);
    if (Status s = dispatcher.start(duration_ns); !s) {
        for (const std::string &e : (*modules)->stopAll()) say(e);
        return refuse(s.error().message);
    }
    for (std::size_t i = 0; i < set->modules.size(); ++i)
        segment->record(executors + i).state.store(static_cast<uint32_t>(stats::ModuleState::Running));
    for (const dispatch::ExecutorReport &r : dispatcher.reports())
        say("executor '" + r.name + "': " + r.detail);
    if (!dispatcher.realtime()) {
        say("WARNING: ************************************************************");
        say("WARNING: NOT REAL-TIME: the dispatcher runs SCHED_OTHER; periods are not guaranteed");
        say("WARNING: and every figure in the stats is marked \"realtime\": false.");
        say("WARNING: ************************************************************");
    }
    say("running " + set->xml_path.string() + ": basic period " + schedule::humanDuration(schedule->basic_ns) +
        ", macro period " + schedule::humanDuration(schedule->macro_ns) + ", " + std::to_string(schedule->slots.size()) +
        " slots, stats in /dev/shm" + segment->name());

    // 4. the non-RT side
    sigset_t stop_signals;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGINT);
    sigaddset(&stop_signals, SIGTERM);
    const timespec tick{0, 20'000'000};
    while (!dispatcher.finished()) {
        int sig = sigtimedwait(&stop_signals, nullptr, &tick);
        drainModuleOutput();
        supervisor.poll();
        for (const hosts::ProcessInfo &p : supervisor.processes())
            segment->record(executors + static_cast<std::size_t>(processes[p.slot]->index))
                .state.store(static_cast<uint32_t>(p.running || p.restart_pending ? stats::ModuleState::Running
                                                                                  : stats::ModuleState::Exited));
        if (sig == SIGINT || sig == SIGTERM) {
            say(std::string("received ") + (sig == SIGINT ? "SIGINT" : "SIGTERM") + ", stopping");
            break;
        }
    }

    // 5. clean stop
    control_server.reset();  // no client reads a set that is going away
    dispatcher.requestStop();
    dispatcher.join();
    if (calls) calls->stop();  // callers still waiting return at once ("irpd is stopping")
    supervisor.stopAll(2'000'000'000);  // stop_requested, then SIGTERM, then SIGKILL
    // From slot 0's due time to the end of the main dispatcher's last slot.
    const int64_t elapsed = header->finished_ns.load() - header->started_ns.load();
    int status = kExitOk;
    for (const std::string &e : (*modules)->stopAll()) {
        say(e);
        status = kExitFailure;
    }
    for (std::size_t i = 0; i < set->modules.size(); ++i)
        segment->record(executors + i).state.store(static_cast<uint32_t>(stats::ModuleState::Stopped));
    drainModuleOutput();
    if (!options.stats_json.empty() &&
        !writeStats(options.stats_json, *set, *schedule, *segment, dispatcher, options, elapsed)) {
        say("error: cannot write " + options.stats_json);
        status = kExitFailure;
    }
    const stats::TimingRecord &main = segment->record(0);
    say("stopped after " + std::to_string(main.runs.load()) + " basic periods: " +
        std::to_string(main.overruns.load()) + " overruns, " + std::to_string(main.missed.load()) + " missed, " +
        std::to_string(main.skipped.load()) + " skipped");
    modules->reset();  // unload
    if (dma_latency_fd >= 0) close(dma_latency_fd);
    return status;
}

} // namespace irp::daemon
