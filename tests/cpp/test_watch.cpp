// test_watch.cpp -- the policies irpd's main thread applies every tick, each on its own, without a
// running irpd: new counts turned into events (EventWatch), a process's hang acted on once per
// release (ProcessHangWatch), the fault stop's safe outputs and the overrun watchdog's hooks, the
// dispatchers' progress, and the previous run's crash record taken in.  Real shared memory (stats
// block, control segment) under instances of their own, removed at the end; the overrun.so
// fixture for a real safe_outputs().
#include "config/module_xml.hpp"
#include "events/event_log.hpp"
#include "hosts/control_segment.hpp"
#include "hosts/thread_module.hpp"
#include "irpd/watch/crash_intake.hpp"
#include "irpd/watch/event_watch.hpp"
#include "irpd/watch/fault_stop.hpp"
#include "irpd/watch/process_hang_watch.hpp"
#include "irpd/watch/progress.hpp"
#include "stats/stats_segment.hpp"
#include "support/subprocess.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <fstream>
#include <set>
#include <string>
#include <vector>

using namespace irp;
using testing_support::readFile;
using testing_support::TempDir;

namespace {

constexpr int64_t kMs = 1'000'000;

std::string uniqueInstance() {
    static std::atomic<int> n{0};
    return "test-watch-" + std::to_string(getpid()) + "-" + std::to_string(n++);
}

// A stats block with records 0..1 for two dispatchers and 2..7 for modules.
struct Stats {
    stats::StatsSegment segment;
    Stats() : segment(std::move(stats::StatsSegment::create(uniqueInstance(), 8).value())) {}
    stats::TimingRecord &record(std::size_t i) { return segment.record(i); }
};

config::ModuleSpec moduleSpec(const std::string &name, int index,
                              config::ModuleType type = config::ModuleType::Thread) {
    config::ModuleSpec m;
    m.name = name;
    m.index = index;
    m.type = type;
    m.period_ns = 10 * kMs;
    return m;
}

// A generation of `modules`, module i on stats record 2 + i (and control slot i for processes).
reload::Generation generationOf(std::vector<config::ModuleSpec> modules) {
    reload::Generation g;
    g.number = 3;
    g.set.xml_path = "/sets/cell/module.xml";
    for (std::size_t i = 0; i < modules.size(); ++i) {
        modules[i].index = static_cast<int>(i);
        reload::Member member;
        member.record = 2 + i;
        if (modules[i].type == config::ModuleType::Process) member.slot = static_cast<int>(i);
        g.members.push_back(member);
    }
    g.set.modules = std::move(modules);
    return g;
}

struct Seen {
    std::string kind, module, message;
};
std::vector<Seen> eventsOf(const events::EventLog &log) {
    std::vector<Seen> all;
    const nlohmann::ordered_json answer = log.since(0, 1000);
    for (const auto &e : answer["events"])
        all.push_back({e["kind"].get<std::string>(), e["module"].is_null() ? "" : e["module"].get<std::string>(),
                       e["message"].get<std::string>()});
    return all;
}
std::vector<std::string> kindsOf(const events::EventLog &log) {
    std::vector<std::string> kinds;
    for (const Seen &e : eventsOf(log)) kinds.push_back(e.kind);
    return kinds;
}

}  // namespace

// ---- EventWatch ---------------------------------------------------------------------------------

TEST(EventWatch, AFaultIsAnEventAtOnceEvenOnTheFirstLook) {
    Stats stats;
    events::EventLog log;
    watch::EventWatch watch(log, stats.segment);
    const reload::Generation g = generationOf({moduleSpec("a", 0), moduleSpec("b", 1)});
    stats.record(3).errors.store(1);  // b threw before the first look
    watch.look(g, {}, false);
    ASSERT_EQ(eventsOf(log).size(), 1u);
    EXPECT_EQ(eventsOf(log)[0].kind, "fault");
    EXPECT_EQ(eventsOf(log)[0].module, "b");
    watch.look(g, {}, true);  // the same count again: nothing new
    EXPECT_EQ(eventsOf(log).size(), 1u);
}

TEST(EventWatch, MissesAndOverrunsAreReportedOnTheOnceASecondLooksOnly) {
    Stats stats;
    events::EventLog log;
    watch::EventWatch watch(log, stats.segment);
    const reload::Generation g = generationOf({moduleSpec("a", 0)});
    stats.record(2).missed.store(5);  // before irpd looked: not news
    watch.look(g, {}, true);
    EXPECT_TRUE(eventsOf(log).empty());
    stats.record(2).missed.store(8);
    stats.record(2).overruns.store(2);
    watch.look(g, {}, false);
    EXPECT_TRUE(eventsOf(log).empty());
    watch.look(g, {}, true);
    const auto seen = eventsOf(log);
    ASSERT_EQ(seen.size(), 2u);
    EXPECT_EQ(seen[0].kind, "deadline");
    EXPECT_EQ(seen[0].message, "3 deadline misses (8 in all)");
    EXPECT_EQ(seen[1].kind, "overrun");
    EXPECT_EQ(seen[1].message, "2 budget overruns (2 in all)");
}

TEST(EventWatch, AWatchedModulesOverrunsAreLeftToTheWatchdog) {
    Stats stats;
    events::EventLog log;
    watch::EventWatch watch(log, stats.segment);
    config::ModuleSpec m = moduleSpec("w", 0);
    m.on_overrun = config::OverrunAction::Warn;
    const reload::Generation g = generationOf({m});
    watch.look(g, {}, true);
    stats.record(2).overruns.store(4);
    watch.look(g, {}, true);
    EXPECT_TRUE(eventsOf(log).empty());
}

TEST(EventWatch, ProcessExitsAndRestartsAtOnceDroppedOutputOnceASecond) {
    Stats stats;
    events::EventLog log;
    watch::EventWatch watch(log, stats.segment);
    const reload::Generation g = generationOf({});
    hosts::ProcessInfo p;
    p.name = "drive";
    p.slot = 1;
    p.exits = 1;
    p.last_exit = "killed by SIGSEGV (Segmentation fault)";
    p.restarts = 1;
    p.dropped_lines = 10;
    watch.look(g, {p}, false);
    EXPECT_EQ(kindsOf(log), (std::vector<std::string>{"process_exit", "process_restart"}));
    EXPECT_EQ(eventsOf(log)[0].message, p.last_exit);
    EXPECT_EQ(eventsOf(log)[1].message, "restarted (1 restarts)");
    watch.look(g, {p}, true);
    ASSERT_EQ(eventsOf(log).size(), 3u);
    EXPECT_EQ(eventsOf(log)[2].kind, "process_output_dropped");
    EXPECT_EQ(eventsOf(log)[2].message, "10 output lines dropped by the rate limit (10 in all)");
    // The same module in another slot (a hot reload's replacement) is another process.
    p.slot = 2;
    watch.look(g, {p}, false);
    EXPECT_EQ(eventsOf(log).size(), 5u);
}

// ---- ProcessHangWatch ---------------------------------------------------------------------------

namespace {

struct Hang {
    Stats stats;
    events::EventLog log;
    std::string instance = uniqueInstance();
    hosts::ControlSegment control = std::move(hosts::ControlSegment::create(instance, 2).value());
    std::vector<pid_t> killed;
    std::vector<dispatch::Fault> stops;
    watch::HangActions act;
    watch::ProcessHangWatch watch;

    Hang() {
        act.process = [](const std::string &module) {
            hosts::ProcessInfo info;
            info.name = module;
            info.running = true;
            info.pid = 4242;
            return std::optional<hosts::ProcessInfo>(info);
        };
        act.kill = [this](pid_t pid) { killed.push_back(pid); };
        act.stop_set = [this](const dispatch::Fault &f) { stops.push_back(f); };
    }
    // Release `seq` of slot 0 began at `at`; done up to `done`.
    void release(uint32_t seq, uint32_t done, int64_t at, uint64_t generation = 1) {
        indurop_process_slot &s = control.slot(0);
        s.release_seq = seq;
        s.done_seq = done;
        s.release_ns = at;
        s.generation = generation;
    }
    reload::Generation hanging(config::OverrunAction action) {
        config::ModuleSpec m = moduleSpec("proc", 0, config::ModuleType::Process);
        m.on_overrun = action;
        m.overrun_limit_ns = 5 * kMs;
        return generationOf({m});
    }
};

}  // namespace

TEST(ProcessHangWatch, ARestartKillsTheProcessOncePerRelease) {
    Hang h;
    const reload::Generation g = h.hanging(config::OverrunAction::Restart);
    h.release(7, 6, 100 * kMs);
    h.watch.look(g, h.control, h.log, h.stats.segment, h.act, 104 * kMs);  // 4 ms: within the limit
    EXPECT_TRUE(h.killed.empty());
    h.watch.look(g, h.control, h.log, h.stats.segment, h.act, 110 * kMs);
    EXPECT_EQ(h.killed, std::vector<pid_t>{4242});
    ASSERT_EQ(eventsOf(h.log).size(), 1u);
    EXPECT_EQ(eventsOf(h.log)[0].kind, "process_hang");
    EXPECT_EQ(eventsOf(h.log)[0].message,
              "release not completed after 10000 us, past its overrun limit 5000 us (on_overrun=restart): killed (pid "
              "4242), restarted per its restart policy");
    h.watch.look(g, h.control, h.log, h.stats.segment, h.act, 130 * kMs);  // the same release: done once
    EXPECT_EQ(h.killed.size(), 1u);
    h.release(7, 6, 100 * kMs, 2);  // the restarted process (a new generation) hangs in a release numbered the same
    h.watch.look(g, h.control, h.log, h.stats.segment, h.act, 130 * kMs);
    EXPECT_EQ(h.killed.size(), 2u);
    EXPECT_TRUE(h.stops.empty());
}

TEST(ProcessHangWatch, ACompletedReleaseIsNoHang) {
    Hang h;
    const reload::Generation g = h.hanging(config::OverrunAction::Restart);
    h.release(7, 7, 0);
    h.watch.look(g, h.control, h.log, h.stats.segment, h.act, 1'000 * kMs);
    EXPECT_TRUE(h.killed.empty());
    EXPECT_TRUE(eventsOf(h.log).empty());
}

TEST(ProcessHangWatch, WarnOnlySaysSo) {
    Hang h;
    const reload::Generation g = h.hanging(config::OverrunAction::Warn);
    h.release(3, 2, 0);
    h.watch.look(g, h.control, h.log, h.stats.segment, h.act, 50 * kMs);
    EXPECT_TRUE(h.killed.empty());
    EXPECT_TRUE(h.stops.empty());
    EXPECT_EQ(kindsOf(h.log), std::vector<std::string>{"process_hang"});
}

TEST(ProcessHangWatch, StopStopsTheSetWithTheFault) {
    Hang h;
    h.stats.segment.describe(2, stats::RecordKind::Module, "proc", "main", 10 * kMs, 1, 0);
    const reload::Generation g = h.hanging(config::OverrunAction::Stop);
    h.release(3, 2, 20 * kMs);
    h.watch.look(g, h.control, h.log, h.stats.segment, h.act, 50 * kMs);
    ASSERT_EQ(h.stops.size(), 1u);
    EXPECT_EQ(h.stops[0].module(), "proc");
    EXPECT_EQ(h.stops[0].action, config::OverrunAction::Stop);
    EXPECT_EQ(h.stops[0].started_ns, 20 * kMs);
    EXPECT_EQ(h.stops[0].limit_ns, 5 * kMs);
    EXPECT_EQ(h.stops[0].elapsed_ns, 30 * kMs);
    EXPECT_NE(eventsOf(h.log)[0].message.find(": set stopped, outputs driven to safe values"), std::string::npos);
    EXPECT_TRUE(h.killed.empty());
}

TEST(ProcessHangWatch, ModulesWithoutOnOverrunAreNotWatched) {
    Hang h;
    const reload::Generation g = h.hanging(config::OverrunAction::None);
    h.release(3, 2, 0);
    h.watch.look(g, h.control, h.log, h.stats.segment, h.act, 1'000 * kMs);
    EXPECT_TRUE(eventsOf(h.log).empty());
}

// ---- the fault stop and the watchdog's hooks ----------------------------------------------------

namespace {

// overrun.so loaded, initialized and started with a journal in `dir`, as module 0 of a generation
// whose module 1 is a process (no thread: nothing to drive).
struct SafeOutputs {
    TempDir dir;
    Stats stats;
    events::EventLog log;
    reload::Generation g;

    SafeOutputs() {
        config::ModuleSpec m = moduleSpec("overrun", 0);
        m.path = std::string(FIXTURE_MODULES) + "/overrun.so";
        m.filename = m.path.string();
        m.properties = {{"journal", (dir.path / "journal").string()}};
        g = generationOf({m, moduleSpec("proc", 1, config::ModuleType::Process)});
        auto loaded = hosts::ThreadModule::load(m);
        EXPECT_TRUE(loaded.ok()) << loaded.error().message;
        if (!loaded.ok()) return;
        g.members[0].thread = std::move(*loaded);
        EXPECT_TRUE(g.members[0].thread->initialize().ok());
        EXPECT_TRUE(g.members[0].thread->start().ok());
        stats.segment.describe(2, stats::RecordKind::Module, "overrun", "main", 10 * kMs, 1, 0);
    }
    ~SafeOutputs() {
        if (!g.members.empty() && g.members[0].thread) (void)g.members[0].thread->stop();
    }
};

}  // namespace

TEST(FaultStop, EveryModuleIsStoppedAndItsSafeOutputsDriven) {
    SafeOutputs s;
    ASSERT_TRUE(s.g.members[0].thread);
    for (std::size_t r : {2, 3}) s.stats.record(r).state.store(static_cast<uint32_t>(stats::ModuleState::Running));
    EXPECT_EQ(watch::driveSafeOutputs(s.g, s.stats.segment, s.log), 1u);
    for (std::size_t r : {2, 3})
        EXPECT_EQ(s.stats.record(r).state.load(), static_cast<uint32_t>(stats::ModuleState::Stopped)) << r;
    EXPECT_EQ(readFile(s.dir.path / "journal"), "start\nsafe_outputs while idle\n");
    EXPECT_TRUE(eventsOf(s.log).empty());
}

TEST(FaultStop, TheWatchdogsHooksReportEveryOverrunAndStopTheSet) {
    SafeOutputs s;
    ASSERT_TRUE(s.g.members[0].thread);
    auto current = std::make_shared<const reload::Generation>(std::move(s.g));
    const dispatch::Watchdog::Hooks hooks = watch::watchdogHooks(
        s.log, [&] { return current; }, s.stats.segment);
    dispatch::Fault f;
    f.kind = dispatch::Fault::Kind::Running;
    f.action = config::OverrunAction::Stop;
    f.record = &s.stats.record(2);
    f.executor = "main";
    f.started_ns = 100 * kMs;
    f.limit_ns = 4 * kMs;
    f.elapsed_ns = 6 * kMs;
    hooks.report(f);
    hooks.stop(f);
    const auto seen = eventsOf(s.log);
    ASSERT_EQ(seen.size(), 2u);
    EXPECT_EQ(seen[0].kind, "overrun");
    EXPECT_EQ(seen[0].module, "overrun");
    EXPECT_EQ(seen[0].message, f.describe());
    EXPECT_EQ(seen[1].kind, "stopped");
    EXPECT_EQ(seen[1].message.rfind(
                  "set stopped by a fault of module 'overrun': outputs of 1 module(s) driven to safe values in ", 0),
              0u)
        << seen[1].message;
    EXPECT_EQ(readFile(s.dir.path / "journal"), "start\nsafe_outputs while idle\n");
    (void)current->members[0].thread->stop();
}

// ---- the dispatchers' progress ------------------------------------------------------------------

namespace {
reload::Generation twoExecutors() {
    reload::Generation g = generationOf({moduleSpec("a", 0), moduleSpec("b", 1)});
    g.disabled = {"b"};
    g.tables = std::make_unique<dispatch::Tables>();
    g.tables->records = {0, 1};
    g.tables->executors.resize(2);
    g.tables->executors[0].basic_ns = 1 * kMs;
    g.tables->executors[1].basic_ns = 10 * kMs;
    return g;
}
}  // namespace

TEST(Progress, EachDispatchersSlotsAndWindow) {
    Stats stats;
    const reload::Generation g = twoExecutors();
    stats.record(0).runs.store(17);
    stats.record(1).runs.store(2);
    EXPECT_EQ(watch::dispatcherProgress(stats.segment, g), (std::vector<uint64_t>{17, 2}));
    EXPECT_EQ(watch::progressWindows(g, 20 * kMs), (std::vector<int64_t>{42 * kMs, 60 * kMs}));
}

TEST(Progress, FirstSlotsAreAwaitedUntilEveryDispatcherRanOne) {
    Stats stats;
    const reload::Generation g = twoExecutors();
    stats.record(0).runs.store(1);
    EXPECT_FALSE(watch::awaitFirstSlots(stats.segment, g, 1 * kMs));  // executor 1 has not run a slot
    stats.record(1).runs.store(1);
    EXPECT_TRUE(watch::awaitFirstSlots(stats.segment, g, 1 * kMs));
}

TEST(Progress, TheStatusLineSaysTheSetGenerationAndEnabledModules) {
    const reload::Generation g = twoExecutors();
    EXPECT_EQ(watch::statusLine(g, true),
              "running /sets/cell/module.xml (generation 3, 1 of 2 modules enabled, real-time)");
    EXPECT_EQ(watch::statusLine(g, false),
              "running /sets/cell/module.xml (generation 3, 1 of 2 modules enabled, NOT real-time)");
}

// ---- the previous run's crash ---------------------------------------------------------------------

namespace {

struct Crashed {
    TempDir dir;
    std::string instance = uniqueInstance();
    config::SetSpec set;
    events::EventLog log;

    Crashed() {
        const std::string xml = "<root>\n"
                                "<module><filename>crashy.so</filename><moduletype>thread</"
                                "moduletype><operationtype>periodic</operationtype>"
                                "<period>1000000</period><priority>1</priority></module>\n"
                                "<module><filename>again.so</filename><moduletype>thread</"
                                "moduletype><operationtype>periodic</operationtype>"
                                "<period>1000000</period><priority>2</priority><on_crash>restart</on_crash></module>\n"
                                "</root>\n";
        std::ofstream(dir.path / "module.xml") << xml;
        set = config::parseModuleXml(dir.path / "module.xml").value();
    }
    // The record the crash handler would have left, blaming `module`.
    std::unique_ptr<supervise::CrashState> after(const std::string &module, int sender_pid = -1) {
        std::ofstream(dir.path / "state" / (instance + ".crash"))
            << "indurop-crash 1\nsignal=11\nsignal_name=SIGSEGV\npid=99\nexecutor=main\nmodule=" << module
            << "\nset=" << watch::canonicalSet(set.xml_path) << "\ngeneration=1\nsender_pid=" << sender_pid << "\n";
        return supervise::CrashState::open(dir.path / "state", instance).value();
    }
};

}  // namespace

TEST(CrashIntake, TheCrashingModuleIsLeftOutOfItsSet) {
    Crashed c;
    std::filesystem::create_directories(c.dir.path / "state");
    auto crash = c.after("crashy");
    watch::takeInCrash(*crash, c.set, c.log);
    const auto seen = eventsOf(c.log);
    ASSERT_EQ(seen.size(), 1u);
    EXPECT_EQ(seen[0].kind, "crash");
    EXPECT_EQ(seen[0].module, "crashy");
    EXPECT_NE(seen[0].message.find("; left out of that set (<on_crash>exclude</on_crash>)"), std::string::npos)
        << seen[0].message;
    EXPECT_EQ(crash->excluded(watch::canonicalSet(c.set.xml_path)), std::set<std::string>{"crashy"});
}

TEST(CrashIntake, OnCrashRestartRunsItAgain) {
    Crashed c;
    std::filesystem::create_directories(c.dir.path / "state");
    auto crash = c.after("again");
    watch::takeInCrash(*crash, c.set, c.log);
    EXPECT_NE(eventsOf(c.log)[0].message.find("; it runs again (<on_crash>restart</on_crash>)"), std::string::npos);
    EXPECT_TRUE(crash->excluded(watch::canonicalSet(c.set.xml_path)).empty());
}

TEST(CrashIntake, ACrashOutsideAnyModuleBlamesNone) {
    Crashed c;
    std::filesystem::create_directories(c.dir.path / "state");
    auto crash = c.after("", 1234);  // a signal sent by another process
    watch::takeInCrash(*crash, c.set, c.log);
    EXPECT_NE(eventsOf(c.log)[0].message.find("blames no module, so none is left out"), std::string::npos)
        << eventsOf(c.log)[0].message;
    EXPECT_TRUE(crash->allExcluded().empty());
}

TEST(CrashIntake, NoRecordNoEvent) {
    Crashed c;
    auto crash = supervise::CrashState::open(c.dir.path / "state", c.instance).value();
    watch::takeInCrash(*crash, c.set, c.log);
    EXPECT_TRUE(eventsOf(c.log).empty());
}
