// daemon.cpp -- irpd from start to clean stop, as resources owned in construction order.
//
// start() builds one resource per step, in the order of kSteps below; each is a member of Daemon
// whose destructor undoes it, declared in that same order:
//   set          module.xml parsed, the slot table built (--print-schedule stops here), non-RT
//                work kept off the dispatchers' CPUs
//   dma latency  /dev/cpu_dma_latency held at 0 (the previous image's descriptor after a restart)
//   state folder the crash records' folder opened (and handed to --user), a crash record read
//   privileges   with --user: that user, keeping CAP_SYS_NICE and CAP_IPC_LOCK
//   crash handler armed on the state folder
//   stats        the stats block (room for a hot reload's old and new modules at once)
//   layout, variables  the set's layout read, the shared-variable segment made from it
//   trace        the trace rings, every page touched before memory is locked
//   alarms       the alarm segment (a source for irpd and for each module a set may hold), every
//                page touched, adopted by this process's libindurop for the thread modules
//   retain       the RETAIN and PERSISTENT values restored from the state folder (docs/retain.md)
//   module cache the content-addressed copies thread modules are loaded from
//   supervision  the process supervisor and the reloader; the crash record taken in (an event,
//                its module left out)
//   first        the first generation: thread modules loaded, initialized, started; the control
//                segment and the table of shared functions; the processes started and ready
//   control      the control socket
//   dispatch     memory locked, the dispatcher threads started, the generation adopted, the
//                overrun watchdog started
//   ready        the start said and logged; after a restart its report; systemd's READY=1 once
//                every dispatcher ran a slot
// The first step that fails says why ("irpd: error: ..."), with its exit status (2: the set or a
// module is refused, 1: the machine refuses); returning releases everything built so far in
// reverse order.  No step cleans up after another.
//
// serve() is the non-RT side: every 20 ms the main thread drains module output, watches the
// processes, turns new faults and misses into events, runs the hot reloads the control thread
// hands it and pings systemd's watchdog while every dispatcher makes progress; until
// SIGINT/SIGTERM, the end of --duration or a `restart`.
//
// stop() is the clean stop, in the documented order (docs/scheduler.md "Stopping",
// docs/hot-reload.md "Managed restart", docs/faults.md): systemd told, the control socket closed
// (no client reads a set that is going away), the dispatchers end their slot, a restart's safe
// outputs, the watchdog, the processes, every module's stop(), --stats-json; the destructors then
// unload the modules and remove the shared memory.  After a `restart` main() executes irpd again
// on the new set (irpd/restart.hpp).
#include "irpd/daemon.hpp"

#include "alarms/alarm_segment.hpp"
#include "config/module_xml.hpp"
#include "control/control_server.hpp"
#include "dispatch/dispatcher.hpp"
#include "dispatch/function_calls.hpp"
#include "dispatch/watchdog.hpp"
#include "events/event_log.hpp"
#include "hosts/control_segment.hpp"
#include "hosts/module_cache.hpp"
#include "hosts/process_supervisor.hpp"
#include "irpd/commands.hpp"
#include "irpd/main_queue.hpp"
#include "irpd/resources.hpp"
#include "irpd/say.hpp"
#include "irpd/watch/crash_intake.hpp"
#include "irpd/watch/event_watch.hpp"
#include "irpd/watch/fault_stop.hpp"
#include "irpd/watch/process_hang_watch.hpp"
#include "irpd/watch/progress.hpp"
#include "osal/clock.hpp"
#include "osal/rt.hpp"
#include "reload/reloader.hpp"
#include "retain/retain_store.hpp"
#include "schedule/schedule.hpp"
#include "sdk/runtime.hpp"
#include "stats/stats_segment.hpp"
#include "stats/summary.hpp"
#include "supervise/crash_record.hpp"
#include "supervise/privileges.hpp"
#include "supervise/systemd_notify.hpp"
#include "trace/trace_rings.hpp"
#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"

#include <nlohmann/json.hpp>

#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <set>

namespace irp::daemon {
namespace {

// The main thread's period.
constexpr int64_t kTickNs = 20'000'000;

// How much longer than WatchdogSec the main thread may take for a hot reload (loading modules,
// waiting up to 5 s for new processes, up to 10 s for the swap) before systemd takes it for a hang.
constexpr int64_t kReloadWatchdogAllowanceNs = 30'000'000'000;

// How much longer than WatchdogSec a managed restart may take (the clean stop, the exec, the new
// set's start, and maybe the fallback's) before systemd takes it for a hang.
constexpr int64_t kRestartWatchdogAllowanceNs = 60'000'000'000;

// Room in the stats block and the control segment for what hot reloads may add.
constexpr std::size_t kMinModuleRecords = 256;
constexpr uint32_t kMinProcessSlots = 16;

// How long READY=1 (and a restart's report) waits for every dispatcher's first slot.
constexpr int64_t kFirstSlotsLimitNs = 2'000'000'000;

void drainModuleOutput() {
    runtime::drainLog([](std::string_view line) {
        std::fwrite(line.data(), 1, line.size(), stdout);
        if (line.empty() || line.back() != '\n') std::fputc('\n', stdout);
    });
    std::fflush(stdout);
}

// --stats-json: the last generation's figures.
bool writeStats(const std::string &path, const reload::Generation &g, const stats::StatsSegment &segment, bool realtime,
                const Options &options, int64_t elapsed_ns) {
    using json = nlohmann::ordered_json;
    json executors = json::array(), modules = json::array();
    for (std::size_t i : g.tables->records) executors.push_back(stats::toJson(segment.record(i)));
    for (const config::ModuleSpec &m : g.set.modules)
        modules.push_back(stats::toJson(segment.record(g.members[static_cast<std::size_t>(m.index)].record)));
    json doc = {{"set", g.set.xml_path.string()},
                {"realtime", realtime},
                {"overrun_policy", dispatch::toString(options.dispatcher.policy)},
                {"basic_period_ns", g.schedule.basic_ns},
                {"macro_period_ns", g.schedule.macro_ns},
                {"generation", g.number},
                {"elapsed_ns", elapsed_ns},
                {"cycles", segment.header()->cycles.load()},
                {"log_lines_dropped", runtime::droppedLogLines()},
                {"stats_dropped", stats::statsDropped(&segment.record(0), g.tables->records)},
                {"dispatcher", executors.at(0)},
                {"executors", executors},
                {"modules", modules}};
    std::ofstream out(path);
    out << doc.dump(2) << "\n";
    return static_cast<bool>(out);
}

class Daemon {
public:
    Daemon(const Options &options, Session &session) : options_(options), session_(session) {}
    // Every resource built so far, released in reverse order.
    ~Daemon() = default;
    Daemon(const Daemon &) = delete;
    Daemon &operator=(const Daemon &) = delete;

    // --print-schedule: the set's slot table, and nothing else built.
    int printSchedule();
    // Every step in order: kExitOk, or the exit status of the first that failed.
    int start();
    // The non-RT side until SIGINT/SIGTERM, the end of --duration or a `restart`.
    void serve();
    // The clean stop; the exit status.
    int stop();

private:
    // One resource built: the member function that builds it, and the exit status its failure means.
    struct Step {
        Status (Daemon::*build)();
        int exit_status;
    };
    static const Step kSteps[];
    // Runs one step; a failure is said, kept for a restart's fallback (main.cpp), and its status.
    int attempt(const Step &step);

    Status readSet();
    Status holdDmaLatency();
    Status openStateFolder();
    Status dropPrivileges();
    Status armCrashHandler();
    Status createStats();
    Status readLayout();
    Status createVariables();
    Status createTraceRings();
    Status createAlarmSegment();
    Status openRetainStore();
    Status openModuleCache();
    Status startSupervision();
    Status startFirstGeneration();
    Status openControlSocket();
    Status startDispatchers();
    Status announce();

    void tellSystemdReady();
    void publishProcessStates(const reload::Generation &g);

    const Options &options_;
    Session &session_;

    // Shared by the resources below; nothing to undo.
    events::EventLog events_;
    dispatch::ForceBoard force_board_;  // the forces the dispatchers apply; none at start (docs/forcing.md)
    Forcing forcing_{force_board_, events_, [this] { return dispatcher_ ? dispatcher_->forcesSeen() : UINT64_MAX; }};
    MainQueue queue_;                                                // control thread -> main thread
    RestartDesk restarts_;                                           // `restart` asks here (irpd/restart.hpp)
    std::atomic<const dispatch::Watchdog *> watchdog_now_{nullptr};  // `status` asks it why a fault stopped the set
    std::optional<RestartPlan> restart_;                             // taken by serve(): stop() runs it
    std::optional<config::SetSpec> set_;
    std::optional<schedule::Schedule> schedule_;
    std::set<int> kept_off_;                       // the CPUs non-RT work was kept off
    std::optional<supervise::Identity> identity_;  // --user
    std::optional<variables::Layout> layout_;

    // The resources, in the order start() builds them: destroyed in reverse.
    DmaLatencyHold dma_latency_;
    std::unique_ptr<supervise::CrashState> crash_;  // null: no state folder (no crash records)
    ArmedCrashHandler crash_handler_;
    std::optional<stats::StatsSegment> stats_;
    std::optional<variables::VariableSegment> vars_;
    std::optional<trace::TraceRings> trace_;
    std::optional<alarms::AlarmSegment> alarms_;
    std::filesystem::path state_dir_;              // "" = none (no crash records, no retain store)
    std::unique_ptr<retain::RetainStore> retain_;  // null: no state folder or no shared variables
    std::optional<hosts::ModuleCache> cache_;
    std::optional<hosts::ProcessSupervisor> supervisor_;
    std::optional<reload::Reloader> reloader_;
    std::optional<hosts::ControlSegment> control_;
    std::unique_ptr<dispatch::CallServer> calls_;  // outlives the dispatcher, which serves its calls
    std::optional<FirstGeneration> first_;
    std::unique_ptr<control::ControlServer> server_;
    std::optional<dispatch::Dispatcher> dispatcher_;
    std::unique_ptr<dispatch::Watchdog> watchdog_;
    supervise::SystemdNotify notify_;
};

// The start-up, in order: each step builds the members of its resource (declared in this order).
const Daemon::Step Daemon::kSteps[] = {
    {&Daemon::readSet, kExitRefused},           {&Daemon::holdDmaLatency, kExitFailure},
    {&Daemon::openStateFolder, kExitFailure},   {&Daemon::dropPrivileges, kExitFailure},
    {&Daemon::armCrashHandler, kExitFailure},   {&Daemon::createStats, kExitFailure},
    {&Daemon::readLayout, kExitRefused},        {&Daemon::createVariables, kExitFailure},
    {&Daemon::createTraceRings, kExitFailure},  {&Daemon::createAlarmSegment, kExitFailure},
    {&Daemon::openRetainStore, kExitFailure},   {&Daemon::openModuleCache, kExitFailure},
    {&Daemon::startSupervision, kExitFailure},  {&Daemon::startFirstGeneration, kExitRefused},
    {&Daemon::openControlSocket, kExitFailure}, {&Daemon::startDispatchers, kExitRefused},
    {&Daemon::announce, kExitFailure},
};

int Daemon::attempt(const Step &step) {
    if (Status st = (this->*step.build)(); !st) {
        std::cerr << "irpd: error: " << st.error().message << std::endl;
        session_.error = st.error();
        return step.exit_status;
    }
    return kExitOk;
}

int Daemon::printSchedule() {
    if (const int status = attempt(kSteps[0]); status != kExitOk) return status;
    if (options_.json)
        std::cout << schedule::toJson(*schedule_, *set_).dump(2) << std::endl;
    else
        std::cout << schedule::formatText(*schedule_, *set_);
    return kExitOk;
}

int Daemon::start() {
    for (const Step &step : kSteps)
        if (const int status = attempt(step); status != kExitOk) {
            dma_latency_.leaveInheritedOpen();  // a restart's fallback image takes it on (main.cpp)
            return status;
        }
    return kExitOk;
}

// ---- the steps, in order ------------------------------------------------------------------------

Status Daemon::readSet() {
    auto set = config::parseModuleXml(options_.config);
    if (!set) return set.error();
    auto schedule = schedule::build(*set, options_.limits);
    if (!schedule) return schedule.error();
    set_ = std::move(*set);
    schedule_ = std::move(*schedule);
    if (options_.print_schedule) return Ok{};
    // The set's shared-variable layout: --layout, else <layout>, else a layout.json beside
    // module.xml (the build puts it there).
    reload::resolveLayout(*set_, options_.layout);
    // Everything of irpd that is not a dispatcher (this thread, the control thread, non-real
    // processes) stays off the dispatchers' CPUs, when there are others.
    std::vector<int> rt_cpus{options_.dispatcher.cpu >= 0 ? options_.dispatcher.cpu : osal::lastAllowedCpu()};
    for (const config::ExecutorSpec &e : set_->executors)
        if (e.cpu >= 0) rt_cpus.push_back(e.cpu);
    if (const std::string rest = osal::keepOffCpus(rt_cpus); !rest.empty()) {
        say("non-RT work on CPUs " + rest);
        kept_off_.insert(rt_cpus.begin(), rt_cpus.end());  // the reloader warns of an executor added elsewhere
    }
    return Ok{};
}

// Root's work first, while irpd has one thread: /dev/cpu_dma_latency, the state folder; then,
// with --user, that user with CAP_SYS_NICE and CAP_IPC_LOCK only.
Status Daemon::holdDmaLatency() {
    if (options_.dispatcher.realtime) dma_latency_ = DmaLatencyHold::take(session_.arrived);
    return Ok{};
}

Status Daemon::openStateFolder() {
    if (!options_.user.empty()) {
        auto who = supervise::resolveIdentity(options_.user, options_.group);
        if (!who) return who.error();
        identity_ = *who;
    }
    const std::filesystem::path dir = options_.state_dir.empty() ? kDefaultStateDir : options_.state_dir;
    Status ready = identity_ ? supervise::handOver(dir, *identity_) : Status{Ok{}};
    if (ready) {
        auto opened = supervise::CrashState::open(dir, options_.instance);
        if (opened) {
            crash_ = std::move(*opened);
            state_dir_ = dir;
        } else
            ready = opened.error();
    }
    if (!ready) {
        if (!options_.state_dir.empty()) return ready.error();  // asked for: it must work
        say("WARNING: " + ready.error().message + "; a crash will leave no record");
    }
    return Ok{};
}

Status Daemon::dropPrivileges() {
    if (!identity_) return Ok{};
    if (!options_.control_socket.empty())
        if (Status st = supervise::prepareFolderFor(options_.control_socket, *identity_); !st) return st;
    if (Status st = supervise::dropPrivileges(*identity_); !st) return st;
    say("switched to user " + identity_->user + ":" + identity_->group + " (" + supervise::describeCredentials() + ")");
    return Ok{};
}

Status Daemon::armCrashHandler() {
    if (!crash_) return Ok{};
    auto armed = ArmedCrashHandler::arm(*crash_);
    if (!armed) return Error{"crash handler: " + armed.error().message};
    crash_handler_ = std::move(*armed);
    crash_->setContext(watch::canonicalSet(set_->xml_path), "", 1);
    return Ok{};
}

Status Daemon::createStats() {
    const std::size_t module_records =
        options_.module_records ? options_.module_records : std::max(kMinModuleRecords, 2 * set_->modules.size());
    auto segment =
        stats::StatsSegment::create(options_.instance, dispatch::Dispatcher::executorCount(*set_) + module_records);
    if (!segment) return segment.error();
    stats_ = std::move(*segment);
    stats::Header *header = stats_->header();
    header->basic_ns = schedule_->basic_ns;
    header->macro_ns = schedule_->macro_ns;
    std::snprintf(header->set_path, sizeof header->set_path, "%s", set_->xml_path.c_str());
    return Ok{};
}

Status Daemon::readLayout() {
    if (set_->layout.empty()) return Ok{};
    auto layout = variables::readLayout(set_->layout);
    if (!layout) return layout.error();
    layout_ = std::move(*layout);
    return Ok{};
}

// Shared variables: the segment exists before any module is loaded.
Status Daemon::createVariables() {
    if (!layout_) return Ok{};
    auto created =
        variables::VariableSegment::create(options_.instance, *layout_, variables::Room{options_.var_headroom});
    if (!created) return created.error();
    vars_ = std::move(*created);
    say("shared variables: " + std::to_string(layout_->variables) + " variables, " +
        std::to_string(layout_->data_size) + " bytes (room for " + std::to_string(vars_->header()->data_capacity) +
        "), layout " + vars_->hash() + ", in /dev/shm" + vars_->name());
    return Ok{};
}

// Sampled by the main dispatcher after every slot; channels set by `trace`.  Created before memory
// is locked, every page touched: the RT thread never faults on them.
Status Daemon::createTraceRings() {
    auto rings = trace::TraceRings::create(options_.instance);
    if (!rings) return rings.error();
    trace_ = std::move(*rings);
    trace_->setBasicPeriod(schedule_->basic_ns);
    return Ok{};
}

// Written by the modules from run() (libindurop's irp::raiseAlarm), read by the agent: created
// before memory is locked, every page touched; a source for irpd and one for each module a set may
// hold (a swap gives a new name a source no module of either set uses, docs/alarms.md).
Status Daemon::createAlarmSegment() {
    auto segment = alarms::AlarmSegment::create(options_.instance, 1 + static_cast<uint32_t>(config::kMaxModules));
    if (!segment) return segment.error();
    alarms_ = std::move(*segment);
    alarms_->adopt();
    return Ok{};
}

// RETAIN and PERSISTENT values back in the segment before any module's initialize(); saved from
// the first period on (startDispatchers) and at the stop.
Status Daemon::openRetainStore() {
    if (!vars_) return Ok{};
    if (state_dir_.empty()) {
        if (!retain::retainedOf(layout_->text).empty())
            say("WARNING: no state folder: RETAIN and PERSISTENT values will not survive a restart");
        return Ok{};
    }
    retain_ = retain::RetainStore::open({state_dir_, options_.instance, options_.retain_interval_ns}, *vars_, events_,
                                        &*alarms_);
    return Ok{};
}

// --module-cache, else a folder of this user's own under /tmp.  An existing folder must be a real
// directory owned by irpd's user (not a link another user planted).
Status Daemon::openModuleCache() {
    std::filesystem::path dir = options_.module_cache;
    if (dir.empty()) dir = "/tmp/indurop-" + std::to_string(getuid()) + "-" + options_.instance + "-modules";
    struct stat st {};
    if (lstat(dir.c_str(), &st) == 0 && (!S_ISDIR(st.st_mode) || st.st_uid != getuid()))
        return Error{"module cache " + dir.string() + " is not a directory owned by uid " + std::to_string(getuid()) +
                     ": remove it or choose --module-cache"};
    auto cache = hosts::ModuleCache::open(dir);
    if (!cache) return cache.error();
    cache_ = std::move(*cache);
    return Ok{};
}

// The process supervisor, and the reloader that every generation is prepared by; the crash that
// ended the previous run is taken in first (its module may be left out of this set).
Status Daemon::startSupervision() {
    supervisor_.emplace([](std::string_view line) {
        std::fwrite(line.data(), 1, line.size(), stdout);
        std::fputc('\n', stdout);
    });
    reload::Services services;
    services.stats = &*stats_;
    services.executors = dispatch::Dispatcher::executorCount(*set_);
    services.vars = vars_ ? &*vars_ : nullptr;
    services.supervisor = &*supervisor_;
    services.cache = &*cache_;
    services.events = &events_;
    services.limits = options_.limits;
    services.dispatcher = options_.dispatcher;
    services.kept_off = kept_off_;
    services.trace = &*trace_;
    services.alarms = &*alarms_;
    services.swapped = [this](const reload::Generation &g) {
        if (g.layout) forcing_.relayout(g.layout->text);
    };
    if (crash_) {
        watch::takeInCrash(*crash_, *set_, events_);
        services.left_out = [c = crash_.get()](const config::SetSpec &s) {
            return c->excluded(watch::canonicalSet(s.xml_path));
        };
        services.forgive = [c = crash_.get(), this](const std::string &module) {
            if (c->forgive(module))
                events_.add("crash_cleared", module, "enabled again: no longer left out after its crash");
        };
    }
    if (services.dispatcher.cpu < 0) services.dispatcher.cpu = osal::lastAllowedCpu();
    reloader_.emplace(services);
    return Ok{};
}

// The first generation.  Once its thread modules started (every export is known), the control
// segment is created: a slot per process module (with room for more) and the table of shared
// functions they may call, served by the owners' executors; then its processes start.
Status Daemon::startFirstGeneration() {
    std::set<std::string> left_out;  // modules of this set left out after a crash
    if (crash_) {
        left_out = crash_->excluded(watch::canonicalSet(set_->xml_path));
        for (const std::string &name : left_out)
            say("module '" + name + "' is left out after it crashed irpd (enable it, or clear_crash, to run it again)");
    }
    std::size_t processes = 0;
    for (const config::ModuleSpec &m : set_->modules) processes += m.type == config::ModuleType::Process;
    const uint32_t slots = options_.process_slots
                               ? std::max(options_.process_slots, static_cast<uint32_t>(processes))
                               : std::max<uint32_t>(kMinProcessSlots, static_cast<uint32_t>(processes));
    const std::string set_id = session_.arrived ? session_.arrived->starting().set_id : "";
    auto first = reloader_->prepare(*set_, nullptr, left_out, set_id, [&](reload::Generation &g) {
        const std::vector<runtime::FunctionExport> exports = runtime::functionExports();
        auto created = hosts::ControlSegment::create(options_.instance, slots, static_cast<uint32_t>(exports.size()));
        if (!created) return Status{created.error()};
        control_ = std::move(*created);
        std::vector<std::string> notes;
        calls_ = dispatch::CallServer::publish(*control_, g.set, exports, notes);
        for (const std::string &n : notes) say("note: " + n);
        reloader_->setControl(&*control_);
        reloader_->setCallServer(calls_.get());
        return Status{Ok{}};
    });
    if (!first) return first.error();
    first_.emplace(std::move(*first), *supervisor_);
    drainModuleOutput();
    return Ok{};
}

// Commands read the running generation; hot reloads run on the main thread (MainQueue).
Status Daemon::openControlSocket() {
    if (options_.control_socket.empty()) return Ok{};
    CommandContext context;
    context.reloader = &*reloader_;
    context.stats = &*stats_;
    context.events = &events_;
    context.queue = &queue_;
    context.options = &options_;
    context.variables_shm = vars_ ? vars_->name() : "";
    context.trace = &*trace_;
    context.alarms = &*alarms_;
    context.vars = vars_ ? &*vars_ : nullptr;
    context.stopped_by = [this] {
        const dispatch::Watchdog *w = watchdog_now_.load();
        return w ? w->stoppedBy() : std::string();
    };
    context.crash = crash_.get();
    context.retain = retain_.get();
    context.restarts = &restarts_;
    context.forcing = vars_ ? &forcing_ : nullptr;
    auto opened = control::ControlServer::open(options_.control_socket, commandHandler(context));
    if (!opened) return opened.error();
    server_ = std::move(*opened);
    return Ok{};
}

// Memory locked, the dispatcher threads started on one T0, the first generation handed to the
// reloader, and the overrun watchdog (docs/faults.md) above the dispatchers: it must run while
// one of them is stuck.
Status Daemon::startDispatchers() {
    if (options_.dispatcher.realtime) {
        if (Status s = osal::lockMemory(); !s) say("WARNING: " + s.error().message + "; page faults may add latency");
        if (!dma_latency_.held())
            say("note: /dev/cpu_dma_latency not held at 0; CPU idle states may add wake-up latency");
    }
    dispatch::DispatcherOptions dispatcher_options = options_.dispatcher;
    dispatcher_options.trace = &*trace_;
    dispatcher_options.forces = &force_board_;
    dispatcher_.emplace(*set_, *(*first_)->tables, *stats_, dispatcher_options, osal::monotonicClock());
    if (Status s = dispatcher_->start(static_cast<int64_t>(options_.duration_s * 1e9)); !s) return s;
    session_.dispatched = true;
    reloader_->adopt(first_->adopt(), *dispatcher_);
    watchdog_ = std::make_unique<dispatch::Watchdog>(
        osal::monotonicClock(),
        dispatch::Watchdog::Executors{[this] { return dispatcher_->executorsVersion(); },
                                      [this] { return dispatcher_->executors(); }},
        dispatcher_->halted(),
        watch::watchdogHooks(
            events_, [this] { return reloader_->current(); }, *stats_));
    // Above the dispatchers, on the non-RT CPUs.
    watchdog_->start(dispatcher_->realtime() ? std::min(99, options_.dispatcher.rt_priority + 1) : 0);
    watchdog_now_.store(watchdog_.get());
    if (retain_) retain_->start();
    return Ok{};
}

// The start said and logged; a restart's report once the first period ran; systemd told.
Status Daemon::announce() {
    for (const dispatch::ExecutorReport &r : dispatcher_->reports()) say("executor '" + r.name + "': " + r.detail);
    if (!dispatcher_->realtime()) {
        say("WARNING: ************************************************************");
        say("WARNING: NOT REAL-TIME: the dispatcher runs SCHED_OTHER; periods are not guaranteed");
        say("WARNING: and every figure in the stats is marked \"realtime\": false.");
        say("WARNING: ************************************************************");
    }
    if (server_) say("control socket " + server_->path());
    say("running " + set_->xml_path.string() + ": basic period " + schedule::humanDuration(schedule_->basic_ns) +
        ", macro period " + schedule::humanDuration(schedule_->macro_ns) + ", " +
        std::to_string(schedule_->slots.size()) + " slots, stats in /dev/shm" + stats_->name());
    events_.add("start", "",
                "irpd " INDUROP_VERSION " started " + set_->xml_path.string() +
                    (dispatcher_->realtime() ? " (real-time)" : " (NOT real-time)"));
    // Start-up: main() to the first period's due time; a restart's downtime once that period ran.
    const stats::Header *header = stats_->header();
    const int64_t startup_ns = header->started_ns.load() - session_.began_ns;
    if (session_.arrived) {
        if (!watch::awaitFirstSlots(*stats_, *reloader_->current(), kFirstSlotsLimitNs))
            say("WARNING: a dispatcher has not completed its first slot within 2 s after the restart");
        reportRestart(*session_.arrived, header->started_ns.load(), startup_ns, restarts_, events_);
    } else {
        restarts_.started(startup_ns, nullptr);
    }
    tellSystemdReady();
    return Ok{};
}

// systemd (Type=notify): ready once every dispatcher ran a slot; the watchdog from then on.
void Daemon::tellSystemdReady() {
    notify_ = supervise::SystemdNotify::fromEnvironment();
    if (session_.arrived) notify_.restoreIntervalAtReady();  // the old image stretched it for the restart
    if (!notify_.active()) return;
    const auto g = reloader_->current();
    if (!watch::awaitFirstSlots(*stats_, *g, kFirstSlotsLimitNs))
        say("WARNING: a dispatcher has not completed its first slot within 2 s; telling systemd READY=1 anyway");
    notify_.ready(watch::statusLine(*g, dispatcher_->realtime()), watch::dispatcherProgress(*stats_, *g),
                  watch::progressWindows(*g, kTickNs), osal::monotonicNow());
    if (!notify_.watchdogNs()) return;
    say("systemd watchdog: " + schedule::humanDuration(notify_.watchdogNs()) +
        "; pinged while every dispatcher makes progress");
    int64_t longest = 0;
    for (const auto &table : g->tables->executors) longest = std::max(longest, table.basic_ns);
    if (longest * 2 > notify_.watchdogNs() / 2)
        say("WARNING: WatchdogSec " + schedule::humanDuration(notify_.watchdogNs()) +
            " is less than 4 basic periods of the slowest dispatcher (" + schedule::humanDuration(longest) +
            "): pings may be missed; lengthen WatchdogSec");
}

// ---- the non-RT side ----------------------------------------------------------------------------

// The modules' state in the stats block follows their processes (running, restarting, exited).
void Daemon::publishProcessStates(const reload::Generation &g) {
    for (const hosts::ProcessInfo &p : supervisor_->processes())
        for (const config::ModuleSpec &m : g.set.modules) {
            const reload::Member &member = g.members[static_cast<std::size_t>(m.index)];
            if (member.slot == static_cast<int>(p.slot) && !g.disabled.count(m.name) && !dispatcher_->isHalted())
                stats_->record(member.record)
                    .state.store(static_cast<uint32_t>(p.running || p.restart_pending ? stats::ModuleState::Running
                                                                                      : stats::ModuleState::Exited));
        }
}

void Daemon::serve() {
    sigset_t stop_signals;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGINT);
    sigaddset(&stop_signals, SIGTERM);
    const timespec tick{0, kTickNs};
    watch::EventWatch watch(events_, *stats_);
    watch::ProcessHangWatch hangs;
    watch::HangActions act;
    act.process = [this](const std::string &module) { return supervisor_->process(module); };
    act.kill = [](pid_t pid) { ::kill(pid, SIGKILL); };
    act.stop_set = [this](const dispatch::Fault &f) { watchdog_->stopSet(f); };
    auto progress = [this] { return watch::dispatcherProgress(*stats_, *reloader_->current()); };
    int64_t last_figures = 0;
    uint64_t generation_told = reloader_->current()->number;
    while (!dispatcher_->finished()) {
        const int sig = sigtimedwait(&stop_signals, nullptr, &tick);
        drainModuleOutput();
        supervisor_->poll();
        if (queue_.pending()) {
            notify_.beginLongWork(kReloadWatchdogAllowanceNs);
            queue_.runPending();
            notify_.endLongWork(progress, osal::monotonicNow);
        }
        const auto g = reloader_->current();
        if (g->number != generation_told) {
            generation_told = g->number;
            if (crash_) crash_->setContext(watch::canonicalSet(g->set.xml_path), g->set_id, g->number);
            notify_.status(watch::statusLine(*g, dispatcher_->realtime()));
            notify_.setDispatchers(watch::dispatcherProgress(*stats_, *g), watch::progressWindows(*g, kTickNs),
                                   osal::monotonicNow());
        }
        publishProcessStates(*g);
        const int64_t now = osal::monotonicNow();
        const bool figures = now - last_figures >= 1'000'000'000;
        if (figures) last_figures = now;
        watch.look(*g, supervisor_->processes(), figures);
        if (control_) hangs.look(*g, *control_, events_, *stats_, act, now);
        notify_.tick(watch::dispatcherProgress(*stats_, *g), now);
        // the crash handler names the stalled dispatcher's module by its marker
        const int stalled = notify_.stalled();
        supervise::CrashState::noteStalled(stalled >= 0 && static_cast<std::size_t>(stalled) < g->tables->markers.size()
                                               ? g->tables->markers[static_cast<std::size_t>(stalled)]
                                               : -1);
        if (sig == SIGINT || sig == SIGTERM) {
            say(std::string("received ") + (sig == SIGINT ? "SIGINT" : "SIGTERM") + ", stopping");
            return;
        }
        if ((restart_ = restarts_.take())) {
            say("restart onto set " + describeSet(restart_->target) + " asked; stopping set " +
                describeSet(restart_->origin) + " (outputs to safe values once the dispatchers stopped)");
            return;
        }
    }
}

// ---- the clean stop -----------------------------------------------------------------------------

// A managed restart's too: systemd is told it reloads, the dispatchers end their slot, then every
// module's safe_outputs() runs (nothing dispatches them any more), then the same stop as always.
int Daemon::stop() {
    const int64_t stop_began = osal::monotonicNow();
    if (restart_)
        notify_.restarting("restarting onto set " + describeSet(restart_->target), kRestartWatchdogAllowanceNs);
    else
        notify_.stopping("stopping");
    queue_.close();
    server_.reset();  // no client reads a set that is going away
    dispatcher_->requestStop();
    dispatcher_->join();
    if (restart_) {
        const std::size_t driven = watch::driveSafeOutputs(*reloader_->current(), *stats_, events_);
        say("outputs of " + std::to_string(driven) + " module(s) driven to safe values for the restart");
    }
    watchdog_now_.store(nullptr);
    watchdog_->stop();
    if (calls_) calls_->stop();  // callers still waiting return at once ("irpd is stopping")
    supervisor_->stopAll(2'000'000'000, restart_.has_value());  // stop_requested, then SIGTERM, then SIGKILL
    // From slot 0's due time to the end of the main dispatcher's last slot.
    const stats::Header *header = stats_->header();
    const int64_t elapsed = header->finished_ns.load() - header->started_ns.load();
    int status = kExitOk;
    for (const std::string &e : reloader_->stopAll()) {
        say(e);
        status = kExitFailure;
    }
    if (retain_) retain_->stop();  // the values the modules' stop() left
    drainModuleOutput();
    if (!options_.stats_json.empty() &&
        !writeStats(options_.stats_json, *reloader_->current(), *stats_, dispatcher_->realtime(), options_, elapsed)) {
        say("error: cannot write " + options_.stats_json);
        status = kExitFailure;
    }
    const stats::TimingRecord &main = stats_->record(0);
    say("stopped after " + std::to_string(main.runs.load()) +
        " basic periods: " + std::to_string(main.overruns.load()) + " overruns, " + std::to_string(main.missed.load()) +
        " missed, " + std::to_string(main.skipped.load()) + " skipped");
    crash_handler_.disarm();
    if (restart_) {  // the descriptor goes to the next image (it may not be allowed to open it again)
        restart_->last_period_ns = header->finished_ns.load();
        restart_->dma_latency_fd = dma_latency_.handOver();
        restart_->stop_ns = osal::monotonicNow() - stop_began;
        session_.restart = std::move(restart_);
    }
    return status;
}

}  // namespace

int run(const Options &options, Session &session) {
    Daemon irpd(options, session);
    if (options.print_schedule) return irpd.printSchedule();
    if (const int status = irpd.start(); status != kExitOk) return status;
    irpd.serve();
    return irpd.stop();
}

}  // namespace irp::daemon
