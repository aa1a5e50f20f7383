// daemon.cpp -- what irpd does, in order:
//   1. parse module.xml and build the slot table (--print-schedule stops here);
//   2. create the stats block, the shared-variable segment, the trace rings; prepare the
//      first generation of the set (reload/reloader.hpp): load, initialize and start the thread
//      modules, create the control segment with the table of shared functions, start the
//      processes;
//   3. lock memory and start the dispatcher threads (SCHED_FIFO, pinned);
//   4. the main thread becomes the non-RT side: tells systemd READY=1 (when started by it), then
//      every 20 ms it drains module output (irp::printf), watches the processes, turns new faults
//      and misses into events, runs the hot reloads the control thread hands it, and pings
//      systemd's watchdog while every dispatcher makes progress; until SIGINT/SIGTERM or the end
//      of --duration;
//   5. stop the dispatchers, stop() every module, write --stats-json, unload, remove the shm; after
//      a `restart` request the same stop, outputs driven to safe values first, and main()
//      executes irpd again on the new set (irpd/restart.hpp).
#include "irpd/daemon.hpp"

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
#include "osal/clock.hpp"
#include "osal/rt.hpp"
#include "reload/reloader.hpp"
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

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>

namespace irp::daemon {
namespace {

void say(const std::string &line) { std::cerr << "irpd: " << line << std::endl; }

void drainModuleOutput() {
    runtime::drainLog([](std::string_view line) {
        std::fwrite(line.data(), 1, line.size(), stdout);
        if (line.empty() || line.back() != '\n') std::fputc('\n', stdout);
    });
    std::fflush(stdout);
}

bool writeStats(const std::string &path, const reload::Generation &g, const stats::StatsSegment &segment,
                const dispatch::Dispatcher &dispatcher, const Options &options, int64_t elapsed_ns) {
    using json = nlohmann::ordered_json;
    json executors = json::array(), modules = json::array();
    for (std::size_t i : g.tables->records) executors.push_back(stats::toJson(segment.record(i)));
    for (const config::ModuleSpec &m : g.set.modules)
        modules.push_back(stats::toJson(segment.record(g.members[static_cast<std::size_t>(m.index)].record)));
    json doc = {{"set", g.set.xml_path.string()},
                {"realtime", dispatcher.realtime()},
                {"overrun_policy", dispatch::toString(options.dispatcher.policy)},
                {"basic_period_ns", g.schedule.basic_ns},
                {"macro_period_ns", g.schedule.macro_ns},
                {"generation", g.number},
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

// The module cache's folder: --module-cache, else one of this user's own under /tmp.  An
// existing folder must be a real directory owned by irpd's user (not a link another user planted).
Result<hosts::ModuleCache> openModuleCache(const Options &options) {
    std::filesystem::path dir = options.module_cache;
    if (dir.empty())
        dir = "/tmp/indurop-" + std::to_string(getuid()) + "-" + options.instance + "-modules";
    struct stat st{};
    if (lstat(dir.c_str(), &st) == 0 && (!S_ISDIR(st.st_mode) || st.st_uid != getuid()))
        return Error{"module cache " + dir.string() + " is not a directory owned by uid " + std::to_string(getuid()) +
                     ": remove it or choose --module-cache"};
    return hosts::ModuleCache::open(dir);
}

// Turns what the RT threads and the supervisor counted since the last look into events: a module
// disabled by a fault, deadline misses and overruns (at most one event per module per second),
// process exits and restarts, output lines a process lost to the rate limit (one a second).
class EventWatch {
public:
    EventWatch(events::EventLog &log, const stats::StatsSegment &stats) : log_(log), stats_(stats) {}

    void look(const reload::Generation &g, const hosts::ProcessSupervisor &supervisor, bool figures) {
        for (const config::ModuleSpec &m : g.set.modules) {
            const stats::TimingRecord &r = stats_.record(g.members[static_cast<std::size_t>(m.index)].record);
            Seen &seen = seen_[m.name];
            const uint64_t errors = r.errors.load(), missed = r.missed.load(), overruns = r.overruns.load();
            // (on the first look too: a module may throw before it, in its first runs)
            if (errors > seen.errors)
                log_.add("fault", m.name, "threw from run() or condition(); disabled (enable it to run it again)");
            if (figures || seen.first) {
                if (missed > seen.missed && !seen.first)
                    log_.add("deadline", m.name, std::to_string(missed - seen.missed) + " deadline misses (" +
                                                     std::to_string(missed) + " in all)");
                // (a module with <on_overrun> has each overrun reported by the watchdog instead)
                if (overruns > seen.overruns && !seen.first && m.on_overrun == config::OverrunAction::None)
                    log_.add("overrun", m.name, std::to_string(overruns - seen.overruns) + " budget overruns (" +
                                                    std::to_string(overruns) + " in all)");
                seen.missed = missed;
                seen.overruns = overruns;
            }
            seen.errors = errors;
            seen.first = false;
        }
        for (const hosts::ProcessInfo &p : supervisor.processes()) {
            Seen &seen = seen_["process:" + p.name + ":" + std::to_string(p.slot)];
            if (p.exits > seen.exits) log_.add("process_exit", p.name, p.last_exit);
            if (p.restarts > seen.restarts) log_.add("process_restart", p.name, "restarted (" + std::to_string(p.restarts) + " restarts)");
            if (p.dropped_lines > seen.dropped && figures)  // at most one a second
                log_.add("process_output_dropped", p.name,
                         std::to_string(p.dropped_lines - seen.dropped) + " output lines dropped by the rate limit (" +
                             std::to_string(p.dropped_lines) + " in all)");
            seen.exits = p.exits;
            seen.restarts = p.restarts;
            if (figures) seen.dropped = p.dropped_lines;
        }
    }

private:
    struct Seen {
        bool first = true;
        uint64_t errors = 0, missed = 0, overruns = 0, exits = 0, restarts = 0, dropped = 0;
    };
    events::EventLog &log_;
    const stats::StatsSegment &stats_;
    std::map<std::string, Seen> seen_;
};

// A periodic process module with <on_overrun> whose release has not completed within its
// <overrun_limit> hangs: warn, kill it (the supervisor restarts it per its `restart` property) or
// stop the set.  Looked at on the main thread every tick; one action per release.
class ProcessHangWatch {
public:
    void look(const reload::Generation &g, hosts::ControlSegment &control, const hosts::ProcessSupervisor &supervisor,
              events::EventLog &log, dispatch::Watchdog &watchdog, stats::StatsSegment &stats, int64_t now) {
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
                const auto info = supervisor.process(m.name);
                if (info && info->running && info->pid > 0) {
                    ::kill(info->pid, SIGKILL);  // reaped by poll(), restarted per its `restart` property
                    message += ": killed (pid " + std::to_string(info->pid) + "), restarted per its restart policy";
                }
            } else if (m.on_overrun == config::OverrunAction::Stop) {
                message += ": set stopped, outputs driven to safe values";
            }
            log.add("process_hang", m.name, message);
            say("module '" + m.name + "': " + message);
            if (m.on_overrun == config::OverrunAction::Stop) watchdog.stopSet(f);
        }
    }

private:
    struct Acted {
        uint64_t generation = 0;
        uint32_t release = 0;
    };
    std::map<int, Acted> acted_;
};

// Every module of the running set marked stopped and, for those that have one, its
// safe_outputs() called (on the calling thread): the fault stop's and the managed restart's first
// step.  How many drove their outputs; a failure is an event.
std::size_t driveSafeOutputs(reload::Reloader &reloader, stats::StatsSegment &stats, events::EventLog &events) {
    const auto g = reloader.current();  // keeps the modules loaded while their hooks run
    std::size_t driven = 0;
    for (const config::ModuleSpec &m : g->set.modules) {
        const reload::Member &member = g->members[static_cast<std::size_t>(m.index)];
        stats.record(member.record).state.store(static_cast<uint32_t>(stats::ModuleState::Stopped));
        if (!member.thread || !member.thread->hasSafeOutputs()) continue;
        if (Status s = member.thread->safeOutputs(); !s) {
            events.add("safe_outputs_failed", m.name, s.error().message);
            say(s.error().message);
            continue;
        }
        ++driven;
    }
    return driven;
}

// The watchdog's hooks: every overrun is an event; a stop drives every module's outputs to safe
// values (their safe_outputs(), on the watchdog's thread, at once) and says so.
dispatch::Watchdog::Hooks watchdogHooks(events::EventLog &events, reload::Reloader &reloader, stats::StatsSegment &stats) {
    dispatch::Watchdog::Hooks hooks;
    hooks.report = [&events](const dispatch::Fault &f) {
        events.add("overrun", f.module(), f.describe());
        if (f.action == config::OverrunAction::Stop || f.kind == dispatch::Fault::Kind::Running)
            say("module '" + f.module() + "': " + f.describe());
    };
    hooks.stop = [&events, &reloader, &stats](const dispatch::Fault &f) {
        const int64_t begun = osal::monotonicNow();
        const std::size_t driven = driveSafeOutputs(reloader, stats, events);
        const int64_t took = osal::monotonicNow() - begun;
        const std::string message = "set stopped by a fault of module '" + f.module() + "': outputs of " +
                                    std::to_string(driven) + " module(s) driven to safe values in " +
                                    std::to_string(took / 1000) + " us (" + std::to_string((begun - f.started_ns - f.limit_ns) / 1000) +
                                    " us after the overrun limit); restart irpd to run the set again";
        events.add("stopped", f.module(), message);
        say(message);
    };
    return hooks;
}

// Each dispatcher's completed slots (of the generation's executors, by their records): what a
// watchdog ping vouches for.
std::vector<uint64_t> dispatcherProgress(const stats::StatsSegment &segment, const reload::Generation &g) {
    std::vector<uint64_t> progress;
    for (std::size_t r : g.tables->records) progress.push_back(segment.record(r).runs.load(std::memory_order_relaxed));
    return progress;
}

// Waits (at most limit_ns) until every dispatcher completed a slot: READY=1 means dispatching.
bool awaitFirstSlots(const stats::StatsSegment &segment, const reload::Generation &g, int64_t limit_ns) {
    const int64_t end = osal::monotonicNow() + limit_ns;
    for (;;) {
        const std::vector<uint64_t> progress = dispatcherProgress(segment, g);
        if (std::all_of(progress.begin(), progress.end(), [](uint64_t runs) { return runs > 0; })) return true;
        if (osal::monotonicNow() > end) return false;
        const timespec pause{0, 1'000'000};
        nanosleep(&pause, nullptr);
    }
}

// A set as crash records name it: its module.xml's canonical path.
std::string canonicalSet(const std::filesystem::path &xml) {
    std::error_code ec;
    std::filesystem::path p = std::filesystem::weakly_canonical(xml, ec);
    return (ec ? std::filesystem::absolute(xml) : p).string();
}

// The crash that ended the previous run: an event, and its module left out of its set from now on
// when its <on_crash> says exclude (the set's module.xml is read again for that if it is not the
// one starting now).
void takeInCrash(supervise::CrashState &crash, const config::SetSpec &starting, events::EventLog &events) {
    const auto &fresh = crash.fresh();
    if (!fresh) return;
    std::string consequence;
    if (fresh->module.empty()) {
        const std::string why = fresh->cause();
        consequence = why == "watchdog" ? "; no dispatcher was stuck in a module, so none is left out"
                      : why == "signal" ? "; a signal sent to the process blames no module, so none is left out"
                                        : "; no module's code was running, so none is left out";
    } else {
        std::optional<config::SetSpec> other;
        const config::SetSpec *set = &starting;
        if (fresh->set != canonicalSet(starting.xml_path)) {
            if (auto parsed = config::parseModuleXml(fresh->set)) other = std::move(*parsed);
            set = other ? &*other : nullptr;
        }
        const config::ModuleSpec *culprit = nullptr;
        if (set)
            for (const config::ModuleSpec &m : set->modules)
                if (m.name == fresh->module) culprit = &m;
        if (culprit && culprit->on_crash == config::CrashPolicy::Restart) {
            consequence = "; it runs again (<on_crash>restart</on_crash>)";
        } else if (Status st = crash.exclude(fresh->set, fresh->module); !st) {
            consequence = "; could not record that it is left out: " + st.error().message;
        } else {
            consequence = "; left out of that set (<on_crash>exclude</on_crash>) until it is enabled again or the "
                          "record is cleared (clear_crash)";
        }
    }
    events.add("crash", fresh->module, fresh->describe() + consequence);
    say("the previous run ended by a crash: " + fresh->describe() + consequence);
}

// /dev/cpu_dma_latency held at 0: the descriptor the previous image of a managed restart kept open
// for this one (which may no longer be root enough to open it), else opened now.
int holdDmaLatency(const Session &session) {
    if (session.arrived && session.arrived->dma_latency_fd >= 0) {
        const int fd = session.arrived->dma_latency_fd;
        std::error_code ec;
        if (std::filesystem::read_symlink("/proc/self/fd/" + std::to_string(fd), ec) == "/dev/cpu_dma_latency") {
            fcntl(fd, F_SETFD, FD_CLOEXEC);
            return fd;
        }
    }
    return osal::holdCpuDmaLatencyZero();
}

// The restart this image came from, once its first period ran: status.last_restart and an event.
void reportRestart(const RestartPlan &plan, int64_t first_period_ns, int64_t startup_ns, RestartDesk &desk,
                   events::EventLog &events) {
    const int64_t downtime = first_period_ns - plan.last_period_ns;
    const std::string ms = std::to_string(downtime / 1'000'000) + "." + std::to_string(downtime / 100'000 % 10) + " ms";
    nlohmann::ordered_json last = {{"from_set_id", plan.origin.set_id.empty() ? nlohmann::ordered_json(nullptr)
                                                                              : nlohmann::ordered_json(plan.origin.set_id)},
                                   {"set_id", plan.target.set_id.empty() ? nlohmann::ordered_json(nullptr)
                                                                         : nlohmann::ordered_json(plan.target.set_id)},
                                   {"downtime_ns", downtime},
                                   {"requested_ns", plan.requested_ns},
                                   {"fell_back", plan.fallback},
                                   {"error", plan.fallback ? nlohmann::ordered_json(plan.error) : nlohmann::ordered_json(nullptr)},
                                   {"stop_ns", plan.stop_ns},
                                   {"startup_ns", startup_ns}};
    desk.started(startup_ns, std::move(last));
    const std::string target = describeSet(plan.target), origin = describeSet(plan.origin);
    if (plan.fallback) {
        const std::string message = "could not start set " + target + " (" + plan.error + "); came back on set " + origin +
                                    ": downtime " + ms + ", from the last period of set " + origin + " to its first again";
        events.add("restart_failed", "", message);
        say(message);
    } else {
        const std::string message = "restarted onto set " + target + ": downtime " + ms + ", from the last period of set " +
                                    origin + " to the first of set " + target;
        events.add("restart", "", message);
        say(message);
    }
}

// How long each dispatcher may go without completing a slot and still count as moving for the
// watchdog: two of its basic periods plus two of the main thread's ticks (it looks once per tick).
std::vector<int64_t> progressWindows(const reload::Generation &g, const timespec &tick) {
    std::vector<int64_t> windows;
    for (const dispatch::Table &table : g.tables->executors)
        windows.push_back(2 * table.basic_ns + 2 * (tick.tv_sec * 1'000'000'000 + tick.tv_nsec));
    return windows;
}

std::string statusLine(const reload::Generation &g, bool realtime) {
    return "running " + g.set.xml_path.string() + " (generation " + std::to_string(g.number) + ", " +
           std::to_string(g.set.modules.size() - g.disabled.size()) + " of " + std::to_string(g.set.modules.size()) +
           " modules enabled, " + (realtime ? "real-time" : "NOT real-time") + ")";
}

// How much longer than WatchdogSec the main thread may take for a hot reload (loading modules,
// waiting up to 5 s for new processes, up to 10 s for the swap) before systemd takes it for a hang.
constexpr int64_t kReloadWatchdogAllowanceNs = 30'000'000'000;

// How much longer than WatchdogSec a managed restart may take (the clean stop, the exec, the new
// set's start, and maybe the fallback's) before systemd takes it for a hang.
constexpr int64_t kRestartWatchdogAllowanceNs = 60'000'000'000;

// Room in the stats block and the control segment for what hot reloads may add.
constexpr std::size_t kMinModuleRecords = 256;
constexpr uint32_t kMinProcessSlots = 16;

} // namespace

int run(const Options &options, Session &session) {
    // Every failure to start: said, kept for a restart's fallback (main.cpp), and the exit status.
    auto fail = [&session](int status, const std::string &message) {
        std::cerr << "irpd: error: " << message << std::endl;
        session.error = message;
        return status;
    };
    // 1. the set and its schedule
    auto set = config::parseModuleXml(options.config);
    if (!set) return fail(kExitRefused, set.error().message);
    auto schedule = schedule::build(*set, options.limits);
    if (!schedule) return fail(kExitRefused, schedule.error().message);
    if (options.print_schedule) {
        if (options.json) std::cout << schedule::toJson(*schedule, *set).dump(2) << std::endl;
        else std::cout << schedule::formatText(*schedule, *set);
        return kExitOk;
    }
    // The set's shared-variable layout: --layout, else <layout>, else a layout.json beside
    // module.xml (the build puts it there).
    reload::resolveLayout(*set, options.layout);

    // Everything of irpd that is not a dispatcher (this thread, the control thread, non-real
    // processes) stays off the dispatchers' CPUs, when there are others.
    std::vector<int> rt_cpus{options.dispatcher.cpu >= 0 ? options.dispatcher.cpu : osal::lastAllowedCpu()};
    for (const config::ExecutorSpec &e : set->executors)
        if (e.cpu >= 0) rt_cpus.push_back(e.cpu);
    std::set<int> kept_off;  // told to the reloader: an executor added online elsewhere is warned about
    if (const std::string rest = osal::keepOffCpus(rt_cpus); !rest.empty()) {
        say("non-RT work on CPUs " + rest);
        kept_off.insert(rt_cpus.begin(), rt_cpus.end());
    }

    // Root's work first, while irpd has one thread: hold /dev/cpu_dma_latency, open the state
    // folder; then, with --user, become that user with CAP_SYS_NICE and CAP_IPC_LOCK only.
    int dma_latency_fd = -1;  // held open while dispatching
    if (options.dispatcher.realtime) dma_latency_fd = holdDmaLatency(session);
    std::optional<supervise::Identity> identity;
    if (!options.user.empty()) {
        auto who = supervise::resolveIdentity(options.user, options.group);
        if (!who) return fail(kExitFailure, who.error().message);
        identity = *who;
    }
    const std::filesystem::path state_dir = options.state_dir.empty() ? kDefaultStateDir : options.state_dir;
    std::unique_ptr<supervise::CrashState> crash;
    Status state_ready = identity ? supervise::handOver(state_dir, *identity) : Status{Ok{}};
    if (state_ready) {
        auto opened = supervise::CrashState::open(state_dir, options.instance);
        if (opened) crash = std::move(*opened);
        else state_ready = opened.error();
    }
    if (!state_ready) {
        if (!options.state_dir.empty()) return fail(kExitFailure, state_ready.error().message);
        say("WARNING: " + state_ready.error().message + "; a crash will leave no record");
    }
    if (identity) {
        if (!options.control_socket.empty())
            if (Status st = supervise::prepareFolderFor(options.control_socket, *identity); !st)
                return fail(kExitFailure, st.error().message);
        if (Status st = supervise::dropPrivileges(*identity); !st) return fail(kExitFailure, st.error().message);
        say("switched to user " + identity->user + ":" + identity->group + " (" + supervise::describeCredentials() + ")");
    }
    if (crash) {
        if (Status st = crash->arm(); !st) return fail(kExitFailure, "crash handler: " + st.error().message);
        crash->setContext(canonicalSet(set->xml_path), "", 1);
    }

    // 2. stats block (room for a hot reload to hold the old and the new modules at once)
    const std::size_t executors = dispatch::Dispatcher::executorCount(*set);
    const std::size_t module_records =
        options.module_records ? options.module_records : std::max(kMinModuleRecords, 2 * set->modules.size());
    auto segment = stats::StatsSegment::create(options.instance, executors + module_records);
    if (!segment) return fail(kExitFailure, segment.error().message);
    stats::Header *header = segment->header();
    header->basic_ns = schedule->basic_ns;
    header->macro_ns = schedule->macro_ns;
    std::snprintf(header->set_path, sizeof header->set_path, "%s", set->xml_path.c_str());

    // Shared variables: the segment exists before any module is loaded.
    std::optional<variables::VariableSegment> vars;
    if (!set->layout.empty()) {
        auto layout = variables::readLayout(set->layout);
        if (!layout) return fail(kExitRefused, layout.error().message);
        auto created = variables::VariableSegment::create(options.instance, *layout, variables::Room{options.var_headroom});
        if (!created) return fail(kExitFailure, created.error().message);
        vars = std::move(*created);
        say("shared variables: " + std::to_string(layout->variables) + " variables, " +
            std::to_string(layout->data_size) + " bytes (room for " + std::to_string(vars->header()->data_capacity) +
            "), layout " + vars->hash() + ", in /dev/shm" + vars->name());
    }
    // Trace rings: sampled by the main dispatcher after every slot; channels set by `trace`.
    // Created before memory is locked, every page touched: the RT thread never faults on them.
    auto trace_rings = trace::TraceRings::create(options.instance);
    if (!trace_rings) return fail(kExitFailure, trace_rings.error().message);
    trace_rings->setBasicPeriod(schedule->basic_ns);

    auto cache = openModuleCache(options);
    if (!cache) return fail(kExitFailure, cache.error().message);

    events::EventLog events;
    MainQueue queue;
    hosts::ProcessSupervisor supervisor([](std::string_view line) {
        std::fwrite(line.data(), 1, line.size(), stdout);
        std::fputc('\n', stdout);
    });
    reload::Services services;
    services.stats = &*segment;
    services.executors = executors;
    services.vars = vars ? &*vars : nullptr;
    services.supervisor = &supervisor;
    services.cache = &*cache;
    services.events = &events;
    services.limits = options.limits;
    services.dispatcher = options.dispatcher;
    services.kept_off = kept_off;
    services.trace = &*trace_rings;
    std::set<std::string> left_out;  // modules of this set left out after a crash
    if (crash) {
        takeInCrash(*crash, *set, events);
        left_out = crash->excluded(canonicalSet(set->xml_path));
        for (const std::string &name : left_out)
            say("module '" + name + "' is left out after it crashed irpd (enable it, or clear_crash, to run it again)");
        services.left_out = [c = crash.get()](const config::SetSpec &s) { return c->excluded(canonicalSet(s.xml_path)); };
        services.forgive = [c = crash.get(), &events](const std::string &module) {
            if (c->forgive(module)) events.add("crash_cleared", module, "enabled again: no longer left out after its crash");
        };
    }
    if (services.dispatcher.cpu < 0) services.dispatcher.cpu = osal::lastAllowedCpu();
    reload::Reloader reloader(services);

    // The first generation.  Once its thread modules started (every export is known), the
    // control segment is created: a slot per process module (with room for more) and the table
    // of shared functions they may call, served by the owners' executors.
    std::optional<hosts::ControlSegment> control;
    std::unique_ptr<dispatch::CallServer> calls;  // outlives the dispatcher (declared before it)
    std::size_t processes = 0;
    for (const config::ModuleSpec &m : set->modules) processes += m.type == config::ModuleType::Process;
    const std::string first_set_id = session.arrived ? session.arrived->starting().set_id : "";
    auto first = reloader.prepare(*set, nullptr, left_out, first_set_id, [&](reload::Generation &g) {
        const std::vector<runtime::FunctionExport> exports = runtime::functionExports();
        auto created = hosts::ControlSegment::create(
            options.instance,
            options.process_slots ? std::max(options.process_slots, static_cast<uint32_t>(processes))
                                  : std::max<uint32_t>(kMinProcessSlots, static_cast<uint32_t>(processes)),
            static_cast<uint32_t>(exports.size()));
        if (!created) return Status{created.error()};
        control = std::move(*created);
        std::vector<std::string> notes;
        calls = dispatch::CallServer::publish(*control, g.set, exports, notes);
        for (const std::string &n : notes) say("note: " + n);
        reloader.setControl(&*control);
        reloader.setCallServer(calls.get());
        return Status{Ok{}};
    });
    if (!first) return fail(kExitRefused, first.error().message);
    drainModuleOutput();

    // The overrun watchdog (docs/faults.md), made once the dispatcher runs; `status` reads it.
    std::atomic<const dispatch::Watchdog *> watchdog_now{nullptr};
    std::unique_ptr<dispatch::Watchdog> watchdog;

    // The control socket: commands read the running generation; hot reloads run on this thread.
    std::unique_ptr<control::ControlServer> control_server;
    RestartDesk restarts;  // `restart` asks here; the main loop takes it (irpd/restart.hpp)
    if (!options.control_socket.empty()) {
        CommandContext context;
        context.reloader = &reloader;
        context.stats = &*segment;
        context.events = &events;
        context.queue = &queue;
        context.options = &options;
        context.variables_shm = vars ? vars->name() : "";
        context.trace = &*trace_rings;
        context.vars = vars ? &*vars : nullptr;
        context.stopped_by = [&watchdog_now] {
            const dispatch::Watchdog *w = watchdog_now.load();
            return w ? w->stoppedBy() : std::string();
        };
        context.crash = crash.get();
        context.restarts = &restarts;
        auto opened = control::ControlServer::open(options.control_socket, commandHandler(context));
        if (!opened) {
            supervisor.stopAll(1'000'000'000);
            for (const auto &m : (*first)->members)
                if (m.thread) (void)m.thread->stop();
            return fail(kExitFailure, opened.error().message);
        }
        control_server = std::move(*opened);
    }

    // 3. dispatchers
    if (options.dispatcher.realtime) {
        if (Status s = osal::lockMemory(); !s) say("WARNING: " + s.error().message + "; page faults may add latency");
        if (dma_latency_fd < 0) say("note: /dev/cpu_dma_latency not held at 0; CPU idle states may add wake-up latency");
    }
    dispatch::DispatcherOptions dispatcher_options = options.dispatcher;
    dispatcher_options.trace = &*trace_rings;
    dispatch::Dispatcher dispatcher(*set, *(*first)->tables, *segment, dispatcher_options, osal::monotonicClock());
    const int64_t duration_ns = static_cast<int64_t>(options.duration_s * 1e9);
    if (Status s = dispatcher.start(duration_ns); !s) {
        control_server.reset();
        supervisor.stopAll(1'000'000'000);
        for (const auto &m : (*first)->members)
            if (m.thread) (void)m.thread->stop();
        return fail(kExitRefused, s.error().message);
    }
    session.dispatched = true;
    reloader.adopt(std::move(*first), dispatcher);
    watchdog = std::make_unique<dispatch::Watchdog>(osal::monotonicClock(),
                                                    [&dispatcher] { return dispatcher.executors(); }, dispatcher.halted(),
                                                    watchdogHooks(events, reloader, *segment));
    // Above the dispatchers (it must run while one of them is stuck), on the non-RT CPUs.
    watchdog->start(dispatcher.realtime() ? std::min(99, options.dispatcher.rt_priority + 1) : 0);
    watchdog_now.store(watchdog.get());
    for (const dispatch::ExecutorReport &r : dispatcher.reports())
        say("executor '" + r.name + "': " + r.detail);
    if (!dispatcher.realtime()) {
        say("WARNING: ************************************************************");
        say("WARNING: NOT REAL-TIME: the dispatcher runs SCHED_OTHER; periods are not guaranteed");
        say("WARNING: and every figure in the stats is marked \"realtime\": false.");
        say("WARNING: ************************************************************");
    }
    if (control_server) say("control socket " + control_server->path());
    say("running " + set->xml_path.string() + ": basic period " + schedule::humanDuration(schedule->basic_ns) +
        ", macro period " + schedule::humanDuration(schedule->macro_ns) + ", " + std::to_string(schedule->slots.size()) +
        " slots, stats in /dev/shm" + segment->name());
    events.add("start", "", "irpd " INDUROP_VERSION " started " + set->xml_path.string() +
                                (dispatcher.realtime() ? " (real-time)" : " (NOT real-time)"));
    // Start-up: main() to the first period's due time; a restart's downtime once that period ran.
    const int64_t startup_ns = header->started_ns.load() - session.began_ns;
    if (session.arrived) {
        if (!awaitFirstSlots(*segment, *reloader.current(), 2'000'000'000))
            say("WARNING: a dispatcher has not completed its first slot within 2 s after the restart");
        reportRestart(*session.arrived, header->started_ns.load(), startup_ns, restarts, events);
    } else {
        restarts.started(startup_ns, nullptr);
    }

    const timespec tick{0, 20'000'000};  // the main thread's period
    // systemd (Type=notify): ready once every dispatcher ran a slot; the watchdog from then on.
    supervise::SystemdNotify notify = supervise::SystemdNotify::fromEnvironment();
    if (session.arrived) notify.restoreIntervalAtReady();  // the old image stretched it for the restart
    if (notify.active()) {
        if (!awaitFirstSlots(*segment, *reloader.current(), 2'000'000'000))
            say("WARNING: a dispatcher has not completed its first slot within 2 s; telling systemd READY=1 anyway");
        notify.ready(statusLine(*reloader.current(), dispatcher.realtime()), dispatcherProgress(*segment, *reloader.current()),
                     progressWindows(*reloader.current(), tick), osal::monotonicNow());
        if (notify.watchdogNs()) {
            say("systemd watchdog: " + schedule::humanDuration(notify.watchdogNs()) +
                "; pinged while every dispatcher makes progress");
            int64_t longest = 0;
            for (const auto &table : reloader.current()->tables->executors) longest = std::max(longest, table.basic_ns);
            if (longest * 2 > notify.watchdogNs() / 2)
                say("WARNING: WatchdogSec " + schedule::humanDuration(notify.watchdogNs()) +
                    " is less than 4 basic periods of the slowest dispatcher (" + schedule::humanDuration(longest) +
                    "): pings may be missed; lengthen WatchdogSec");
        }
    }

    // 4. the non-RT side
    sigset_t stop_signals;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGINT);
    sigaddset(&stop_signals, SIGTERM);
    EventWatch watch(events, *segment);
    ProcessHangWatch hangs;
    int64_t last_figures = 0;
    uint64_t generation_told = reloader.current()->number;
    std::optional<RestartPlan> restart;  // a managed restart asked through `restart`
    while (!dispatcher.finished()) {
        int sig = sigtimedwait(&stop_signals, nullptr, &tick);
        drainModuleOutput();
        supervisor.poll();
        if (queue.pending()) {
            notify.beginLongWork(kReloadWatchdogAllowanceNs);
            queue.runPending();
            notify.endLongWork([&] { return dispatcherProgress(*segment, *reloader.current()); }, osal::monotonicNow);
        }
        const auto g = reloader.current();
        if (g->number != generation_told) {
            generation_told = g->number;
            if (crash) crash->setContext(canonicalSet(g->set.xml_path), g->set_id, g->number);
            notify.status(statusLine(*g, dispatcher.realtime()));
            notify.setDispatchers(dispatcherProgress(*segment, *g), progressWindows(*g, tick), osal::monotonicNow());
        }
        for (const hosts::ProcessInfo &p : supervisor.processes())
            for (const config::ModuleSpec &m : g->set.modules) {
                const reload::Member &member = g->members[static_cast<std::size_t>(m.index)];
                if (member.slot == static_cast<int>(p.slot) && !g->disabled.count(m.name) && !dispatcher.isHalted())
                    segment->record(member.record)
                        .state.store(static_cast<uint32_t>(p.running || p.restart_pending ? stats::ModuleState::Running
                                                                                          : stats::ModuleState::Exited));
            }
        const int64_t now = osal::monotonicNow();
        const bool figures = now - last_figures >= 1'000'000'000;
        if (figures) last_figures = now;
        watch.look(*g, supervisor, figures);
        if (control) hangs.look(*g, *control, supervisor, events, *watchdog, *segment, now);
        notify.tick(dispatcherProgress(*segment, *g), now);
        // the crash handler names the stalled dispatcher's module by its marker
        const int stalled = notify.stalled();
        supervise::CrashState::noteStalled(stalled >= 0 && static_cast<std::size_t>(stalled) < g->tables->markers.size()
                                               ? g->tables->markers[static_cast<std::size_t>(stalled)]
                                               : -1);
        if (sig == SIGINT || sig == SIGTERM) {
            say(std::string("received ") + (sig == SIGINT ? "SIGINT" : "SIGTERM") + ", stopping");
            break;
        }
        if ((restart = restarts.take())) {
            say("restart onto set " + describeSet(restart->target) + " asked; stopping set " +
                describeSet(restart->origin) + " (outputs to safe values once the dispatchers stopped)");
            break;
        }
    }

    // 5. clean stop -- a managed restart's too: systemd is told it reloads, the dispatchers end
    // their slot, then every module's safe_outputs() runs (nothing dispatches them any more), then
    // the same stop as always; main() executes the next image.
    const int64_t stop_began = osal::monotonicNow();
    if (restart)
        notify.restarting("restarting onto set " + describeSet(restart->target), kRestartWatchdogAllowanceNs);
    else
        notify.stopping("stopping");
    queue.close();
    control_server.reset();  // no client reads a set that is going away
    dispatcher.requestStop();
    dispatcher.join();
    if (restart) {
        const std::size_t driven = driveSafeOutputs(reloader, *segment, events);
        say("outputs of " + std::to_string(driven) + " module(s) driven to safe values for the restart");
    }
    watchdog_now.store(nullptr);
    watchdog->stop();
    if (calls) calls->stop();  // callers still waiting return at once ("irpd is stopping")
    supervisor.stopAll(2'000'000'000, restart.has_value());  // stop_requested, then SIGTERM, then SIGKILL
    // From slot 0's due time to the end of the main dispatcher's last slot.
    const int64_t elapsed = header->finished_ns.load() - header->started_ns.load();
    int status = kExitOk;
    for (const std::string &e : reloader.stopAll()) {
        say(e);
        status = kExitFailure;
    }
    drainModuleOutput();
    const auto last = reloader.current();
    if (!options.stats_json.empty() && !writeStats(options.stats_json, *last, *segment, dispatcher, options, elapsed)) {
        say("error: cannot write " + options.stats_json);
        status = kExitFailure;
    }
    const stats::TimingRecord &main = segment->record(0);
    say("stopped after " + std::to_string(main.runs.load()) + " basic periods: " +
        std::to_string(main.overruns.load()) + " overruns, " + std::to_string(main.missed.load()) + " missed, " +
        std::to_string(main.skipped.load()) + " skipped");
    if (crash) crash->disarm();
    if (restart) {  // the descriptor goes to the next image (it may not be allowed to open it again)
        restart->last_period_ns = header->finished_ns.load();
        restart->dma_latency_fd = dma_latency_fd;
        restart->stop_ns = osal::monotonicNow() - stop_began;
        session.restart = std::move(restart);
        return status;
    }
    if (dma_latency_fd >= 0) close(dma_latency_fd);
    return status;
}

} // namespace irp::daemon
