// test_process.cpp -- process modules end to end: real executables (tests/cpp/processes/) started
// by the real ProcessSupervisor on a real control segment, released and awaited by the test
// through their slots with the futex helpers, as irpd's dispatcher does; and shared variables
// by path (channel::Handle, read/write) in this process and in a child.
#include "hosts/control_segment.hpp"
#include "hosts/process_supervisor.hpp"
#include "osal/rt.hpp"
#include "support/subprocess.hpp"
#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"

#include <indurop/generated.h>  // the test .glb (joint, m, test::cell, test::other)
#include <indurop/indurop.h>

#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

using namespace irp;
using hosts::ControlSegment;
using hosts::ProcessLaunch;
using hosts::ProcessSupervisor;

namespace {

constexpr int64_t kMs = 1'000'000;
constexpr int64_t kLong = 20'000 * kMs;  // waits that only end early: never a timing assertion

int64_t nowNs() { return irp::monotonicNs(); }

std::string uniqueInstance() {
    static int n = 0;
    return "test-proc-" + std::to_string(getpid()) + "-" + std::to_string(++n);
}

std::string fixturePath(const std::string &file) { return std::string(FIXTURE_PROCESSES) + "/" + file; }

config::ModuleSpec processSpec(const std::string &name, const std::string &file,
                               config::OperationType operation = config::OperationType::Periodic,
                               std::vector<std::pair<std::string, std::string>> props = {}) {
    config::ModuleSpec m;
    m.name = name;
    m.filename = "./" + file;
    m.path = fixturePath(file);
    m.type = config::ModuleType::Process;
    m.operation = operation;
    m.period_ns = operation == config::OperationType::Periodic ? 1'000'000 : 0;
    m.deadline_ns = operation == config::OperationType::Sporadic ? 10'000'000 : 0;
    m.priority = 1;
    m.properties = std::move(props);
    auto parsed = config::parseProcessProperties(m.properties);  // as module.xml's parser does
    if (!parsed)
        ADD_FAILURE() << parsed.error().message;
    else
        m.process = std::move(*parsed);
    m.where = "sets/test/module.xml:9";
    m.line = 9;
    return m;
}

// What irpd's dispatcher does for one release of slot s; returns the release's sequence number.
uint32_t release(indurop_process_slot &s, uint64_t cycle) {
    std::atomic_ref<uint64_t>(s.cycle).store(cycle, std::memory_order_relaxed);
    std::atomic_ref<int64_t>(s.planned_ns)
        .store(5'000'000'000 + static_cast<int64_t>(cycle) * 1'000'000, std::memory_order_relaxed);
    std::atomic_ref<int64_t>(s.basic_ns).store(1'000'000, std::memory_order_relaxed);
    std::atomic_ref<int64_t>(s.release_ns).store(nowNs(), std::memory_order_relaxed);
    const uint32_t seq = std::atomic_ref<uint32_t>(s.release_seq).fetch_add(1, std::memory_order_release) + 1;
    futex::wakeAll(&s.release_seq);
    return seq;
}

// Waits (futex) until the process reported release seq done.
bool awaitDone(indurop_process_slot &s, uint32_t seq, int64_t timeout_ns) {
    const int64_t deadline = nowNs() + timeout_ns;
    for (;;) {
        const uint32_t done = std::atomic_ref<uint32_t>(s.done_seq).load(std::memory_order_acquire);
        if (done == seq) return true;
        const int64_t left = deadline - nowNs();
        if (left <= 0) return false;
        futex::waitWhileEqual(&s.done_seq, done, left);
    }
}

uint32_t stateOf(indurop_process_slot &s) { return std::atomic_ref<uint32_t>(s.state).load(); }

bool pidGone(pid_t pid) {
    if (kill(pid, 0) != 0) return errno == ESRCH;
    // A zombie nobody reaped yet (PID 1 of a container may not reap) is dead too.
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string line;
    std::getline(stat, line);
    const auto close = line.rfind(')');
    return close != std::string::npos && close + 2 < line.size() && (line[close + 2] == 'Z' || line[close + 2] == 'X');
}

// A control segment, the supervisor with a sink that keeps every line, and the helpers to drive them.
struct Harness {
    std::vector<std::string> lines;
    std::string instance = uniqueInstance();
    std::optional<ControlSegment> control;
    ProcessSupervisor supervisor{[this](std::string_view line) { lines.emplace_back(line); }};

    explicit Harness(uint32_t slots = 4) {
        auto c = ControlSegment::create(instance, slots);
        if (!c)
            ADD_FAILURE() << c.error().message;
        else
            control = std::move(*c);
    }
    ~Harness() { supervisor.stopAll(2'000 * kMs); }

    indurop_process_slot &slot(uint32_t i) { return control->slot(i); }

    ProcessLaunch launch(config::ModuleSpec spec, uint32_t slot, std::string variables = "") {
        ProcessLaunch l;
        l.spec = std::move(spec);
        l.slot = slot;
        l.control_shm = control->name();
        l.variables_shm = std::move(variables);
        return l;
    }

    bool has(const std::string &text) const {
        for (const auto &l : lines)
            if (l.find(text) != std::string::npos) return true;
        return false;
    }
    std::string all() const {
        std::string s;
        for (const auto &l : lines) s += l + "\n";
        return s;
    }
    // Polls the supervisor until a line holds text.
    bool waitFor(const std::string &text, int64_t timeout_ns = kLong) {
        const int64_t deadline = nowNs() + timeout_ns;
        while (nowNs() < deadline) {
            supervisor.poll();
            if (has(text)) return true;
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
        return false;
    }
    // Polls the supervisor until pred(info of name) holds.
    template <class Pred>
    bool waitUntil(const std::string &name, Pred pred, int64_t timeout_ns = kLong) {
        const int64_t deadline = nowNs() + timeout_ns;
        while (nowNs() < deadline) {
            supervisor.poll();
            if (auto p = supervisor.process(name); p && pred(*p)) return true;
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
        return false;
    }
    hosts::ProcessInfo info(const std::string &name) const { return supervisor.process(name).value(); }
};

// A shared-variable segment of the test .glb, adopted by this process's libindurop too.
struct Variables {
    std::optional<variables::VariableSegment> segment;
    explicit Variables(const char *layout_path = TEST_VARS_LAYOUT) {
        auto layout = variables::readLayout(layout_path);
        if (!layout) {
            ADD_FAILURE() << layout.error().message;
            return;
        }
        auto s = variables::VariableSegment::create(uniqueInstance(), *layout);
        if (!s)
            ADD_FAILURE() << s.error().message;
        else
            segment = std::move(*s);
    }
    std::string name() const { return segment->name(); }
};

}  // namespace

// ---- lifecycle ----------------------------------------------------------------------------------

TEST(ProcessLifecycle, ReleasedAndAwaitedThroughItsSlot) {
    Harness h;
    ASSERT_TRUE(h.supervisor.start(h.launch(processSpec("cyc", "proc_periodic.exe"), 1)).ok());
    Status ready = h.supervisor.waitReady(kLong);
    ASSERT_TRUE(ready.ok()) << ready.error().message << "\n" << h.all();
    indurop_process_slot &s = h.slot(1);
    EXPECT_EQ(stateOf(s), INDUROP_PROCESS_READY);
    EXPECT_EQ(s.pid, h.info("cyc").pid);
    EXPECT_EQ(s.generation, 1u);
    EXPECT_STREQ(s.name, "cyc");
    EXPECT_EQ(s.kind, 0u);

    for (uint64_t k = 0; k < 5; ++k) {
        const uint64_t cycle = 100 + 3 * k;
        const uint32_t seq = release(s, cycle);
        ASSERT_TRUE(awaitDone(s, seq, kLong)) << "release " << seq << " not reported done\n" << h.all();
        EXPECT_EQ(s.done_seq, s.release_seq);
        EXPECT_GE(s.done_ns, s.release_ns);
        // irp::cycle() in the process is what the slot carried.
        const std::string expected = "[cyc] period n=" + std::to_string(k + 1) + " cycle=" + std::to_string(cycle) +
                                     " slot=" + std::to_string(cycle) +
                                     " planned=" + std::to_string(5'000'000'000 + cycle * 1'000'000) + " basic=1000000";
        EXPECT_TRUE(h.waitFor(expected)) << h.all();
    }
    EXPECT_EQ(stateOf(s), INDUROP_PROCESS_READY);

    // A stop request makes waitPeriod() return -1: the process leaves on its own.
    h.supervisor.stopAll(5'000 * kMs);
    EXPECT_TRUE(h.has("[cyc] stop requested after 5 periods")) << h.all();
    const auto info = h.info("cyc");
    EXPECT_FALSE(info.running);
    EXPECT_EQ(info.last_exit, "exited with status 0");
    EXPECT_EQ(info.starts, 1u);
    EXPECT_EQ(info.exits, 1u);
    EXPECT_EQ(info.crashes, 0u);
    EXPECT_EQ(stateOf(s), INDUROP_PROCESS_EXITED);
}

// A release made ahead (control.h): the process starts it no sooner than its release_at_ns,
// claims it (release_at_ns 0, started_ns written), and one that irpd takes back before that is
// reported done without being run; one that irpd makes immediate runs at once.
TEST(ProcessLifecycle, AReleaseMadeAheadRunsAtItsTimeUnlessTakenBackOrMadeImmediate) {
    Harness h;
    ASSERT_TRUE(h.supervisor.start(h.launch(processSpec("cyc", "proc_periodic.exe"), 0)).ok());
    ASSERT_TRUE(h.supervisor.waitReady(kLong).ok()) << h.all();
    indurop_process_slot &s = h.slot(0);
    std::atomic_ref<int64_t> at(s.release_at_ns);
    auto ahead = [&](uint64_t cycle, int64_t release_at) {
        at.store(release_at, std::memory_order_relaxed);
        return release(s, cycle);
    };

    // Ahead by 50 ms: run then, not before.
    const int64_t when = nowNs() + 50 * kMs;
    uint32_t seq = ahead(7, when);
    ASSERT_TRUE(awaitDone(s, seq, kLong)) << h.all();
    EXPECT_GE(s.started_ns, when);
    EXPECT_GE(s.done_ns, when);
    EXPECT_EQ(at.load(), 0) << "claimed";
    EXPECT_TRUE(h.waitFor("[cyc] period n=1 cycle=7 ")) << h.all();

    // Ahead by 10 s, taken back at once: done without running.
    seq = ahead(8, nowNs() + 10'000 * kMs);
    int64_t expected = at.load();
    ASSERT_TRUE(at.compare_exchange_strong(expected, INDUROP_RELEASE_CANCELLED));
    futex::wakeAll(futex::lowWord(&s.release_at_ns));
    ASSERT_TRUE(awaitDone(s, seq, kLong)) << "a release taken back is reported done\n" << h.all();
    EXPECT_EQ(stateOf(s), INDUROP_PROCESS_READY);

    // Ahead by 10 s, made immediate: runs now (the period after the taken-back one is its second).
    const int64_t made = nowNs();
    seq = ahead(9, made + 10'000 * kMs);
    expected = at.load();
    ASSERT_TRUE(at.compare_exchange_strong(expected, 0));
    futex::wakeAll(futex::lowWord(&s.release_at_ns));  // as irpd makes a release now
    ASSERT_TRUE(awaitDone(s, seq, kLong)) << h.all();
    EXPECT_LT(s.done_ns, made + 5'000 * kMs) << "it did not wait for the time it was first given";
    EXPECT_TRUE(h.waitFor("[cyc] period n=2 cycle=9 ")) << h.all();
    EXPECT_FALSE(h.has("cycle=8 ")) << "the release taken back ran\n" << h.all();
}

TEST(ProcessLifecycle, ArgsAndEnvPropertiesReachTheChild) {
    setenv("INDUROP_TEST_INHERITED", "from-irpd", 1);
    const int leaked = open("/dev/null", O_RDONLY);  // no O_CLOEXEC: the child must not get it
    ASSERT_GE(leaked, 3);
    Harness h;
    auto spec =
        processSpec("argenv", "proc_periodic.exe", config::OperationType::NonReal,
                    {{"args", R"(--env FOO --env INDUROP_MODULE --env INDUROP_SLOT --env INDUROP_CTL)"
                              R"( --env INDUROP_SHM --env INDUROP_TEST_INHERITED "two words" "q\"uote" --no-init)"},
                     {"env.FOO", "bar baz"}});
    ASSERT_TRUE(h.supervisor.start(h.launch(spec, 2)).ok());
    unsetenv("INDUROP_TEST_INHERITED");
    close(leaked);
    ASSERT_TRUE(h.waitFor("[argenv] fds=")) << h.all();
    EXPECT_TRUE(h.has("[argenv] arg[13]=two words")) << h.all();
    EXPECT_TRUE(h.has("[argenv] arg[14]=q\"uote")) << h.all();
    EXPECT_TRUE(h.has("[argenv] start pid=" + std::to_string(h.info("argenv").pid) + " argc=16")) << h.all();
    EXPECT_TRUE(h.has("[argenv] env FOO=bar baz")) << h.all();
    EXPECT_TRUE(h.has("[argenv] env INDUROP_MODULE=argenv")) << h.all();
    EXPECT_TRUE(h.has("[argenv] env INDUROP_SLOT=2")) << h.all();
    EXPECT_TRUE(h.has("[argenv] env INDUROP_CTL=" + h.control->name())) << h.all();
    EXPECT_TRUE(h.has("[argenv] env INDUROP_SHM=(unset)")) << h.all();
    EXPECT_TRUE(h.has("[argenv] env INDUROP_TEST_INHERITED=from-irpd")) << h.all();
    EXPECT_TRUE(h.has("[argenv] cwd=" + std::string(FIXTURE_PROCESSES))) << h.all();
    EXPECT_TRUE(h.has("[argenv] stdin=not a tty")) << h.all();
    EXPECT_TRUE(h.has("[argenv] fds=0,1,2")) << h.all();  // nothing inherited but the three
    EXPECT_TRUE(h.has("[argenv] pgrp=own")) << h.all();
    EXPECT_TRUE(h.has("[argenv] sched=OTHER prio=0")) << h.all();
    // A non-real process is not waited for, even though it never joins the handshake.
    EXPECT_TRUE(h.supervisor.waitReady(50 * kMs).ok());
    EXPECT_EQ(h.slot(2).kind, 2u);
}

TEST(ProcessLifecycle, RealTimePriorityAndCpuOrOneReportEach) {
    Harness h;
    const int cpu = osal::lastAllowedCpu();
    auto l = h.launch(processSpec("rt", "proc_periodic.exe", config::OperationType::Periodic,
                                  {{"args", "--crash-at 1"}, {"restart_delay_ms", "1"}, {"max_restarts", "1"}}),
                      0);
    l.rt_priority = 5;
    l.cpu = cpu;
    ASSERT_TRUE(h.supervisor.start(l).ok());
    ASSERT_TRUE(h.supervisor.waitReady(kLong).ok()) << h.all();
    release(h.slot(0), 1);  // crash, restart: the second start must not repeat a refusal
    ASSERT_TRUE(h.waitUntil("rt", [](const hosts::ProcessInfo &p) { return p.starts == 2; })) << h.all();
    ASSERT_TRUE(h.supervisor.waitReady(kLong).ok()) << h.all();
    auto count = [&](const std::string &text) {
        return std::count_if(h.lines.begin(), h.lines.end(),
                             [&](const std::string &l) { return l.find(text) != std::string::npos; });
    };
    ASSERT_TRUE(h.waitUntil("rt", [&](const hosts::ProcessInfo &) { return count("[rt] fds=") == 2; })) << h.all();
    // Either granted, or refused with one line for both starts (a container may refuse SCHED_FIFO).
    EXPECT_TRUE(count("[rt] sched=FIFO prio=5") == 2 ||
                (count("SCHED_FIFO priority 5 refused") == 1 && count("[rt] sched=OTHER prio=0") == 2))
        << h.all();
    EXPECT_TRUE(count("[rt] cpus=" + std::to_string(cpu)) == 2 || count("cannot pin it to CPU") == 1) << h.all();
}

TEST(ProcessLifecycle, NotReadyInTimeIsNamed) {
    Harness h;
    ASSERT_TRUE(h.supervisor
                    .start(h.launch(processSpec("sleepy", "proc_periodic.exe", config::OperationType::Periodic,
                                                {{"args", "--no-init"}}),
                                    0))
                    .ok());
    Status ready = h.supervisor.waitReady(200 * kMs);
    ASSERT_FALSE(ready.ok());
    EXPECT_NE(ready.error().message.find("'sleepy' (pid " + std::to_string(h.info("sleepy").pid) + ") not ready"),
              std::string::npos)
        << ready.error().message;
    EXPECT_NE(ready.error().message.find("irp::initPeriodExe()"), std::string::npos);
    EXPECT_EQ(stateOf(h.slot(0)), INDUROP_PROCESS_STARTING);
}

// ---- exits and restarts -------------------------------------------------------------------------

TEST(ProcessRestart, CrashIsLoggedCountedAndRestartedOnFailure) {
    Harness h;
    auto spec = processSpec("crashy", "proc_periodic.exe", config::OperationType::Periodic,
                            {{"args", "--crash-at 2"}, {"restart", "on-failure"}, {"restart_delay_ms", "20"}});
    ASSERT_TRUE(h.supervisor.start(h.launch(spec, 0)).ok());
    ASSERT_TRUE(h.supervisor.waitReady(kLong).ok()) << h.all();
    indurop_process_slot &s = h.slot(0);
    const pid_t first = h.info("crashy").pid;
    ASSERT_TRUE(awaitDone(s, release(s, 1), kLong));
    release(s, 2);  // it raises SIGSEGV in this period
    ASSERT_TRUE(h.waitUntil("crashy", [](const hosts::ProcessInfo &p) { return p.exits == 1; })) << h.all();
    auto info = h.info("crashy");
    EXPECT_EQ(info.crashes, 1u);
    EXPECT_NE(info.last_exit.find("killed by SIGSEGV"), std::string::npos) << info.last_exit;
    EXPECT_TRUE(h.has("process module 'crashy' (pid " + std::to_string(first) + ") killed by SIGSEGV")) << h.all();
    EXPECT_TRUE(h.has("restarting in 20 ms (restart=on-failure)")) << h.all();

    ASSERT_TRUE(h.waitUntil("crashy", [](const hosts::ProcessInfo &p) { return p.running && p.restarts == 1; }))
        << h.all();
    info = h.info("crashy");
    EXPECT_EQ(info.starts, 2u);
    EXPECT_NE(info.pid, first);
    ASSERT_TRUE(h.supervisor.waitReady(kLong).ok()) << h.all();
    EXPECT_EQ(s.generation, 2u);
    EXPECT_EQ(s.pid, info.pid);
    // The new process serves the next release.
    ASSERT_TRUE(awaitDone(s, release(s, 3), kLong)) << h.all();
    EXPECT_TRUE(h.waitFor("[crashy] period n=1 cycle=3")) << h.all();
}

TEST(ProcessRestart, CrashWithRestartNeverStaysDown) {
    Harness h;
    auto spec = processSpec("once", "proc_periodic.exe", config::OperationType::Periodic,
                            {{"args", "--crash-at 1"}, {"restart", "never"}});
    ASSERT_TRUE(h.supervisor.start(h.launch(spec, 0)).ok());
    ASSERT_TRUE(h.supervisor.waitReady(kLong).ok()) << h.all();
    release(h.slot(0), 1);
    ASSERT_TRUE(h.waitUntil("once", [](const hosts::ProcessInfo &p) { return p.exits == 1; })) << h.all();
    const auto info = h.info("once");
    EXPECT_EQ(info.crashes, 1u);
    EXPECT_FALSE(info.running);
    EXPECT_FALSE(info.restart_pending);
    EXPECT_EQ(info.restarts, 0u);
    EXPECT_TRUE(h.has("not restarted (restart=never)")) << h.all();
    EXPECT_EQ(stateOf(h.slot(0)), INDUROP_PROCESS_EXITED);
    EXPECT_EQ(h.slot(0).pid, 0);
}

TEST(ProcessRestart, CleanExitRestartedWithAlwaysUpToMaxRestarts) {
    Harness h;
    auto spec = processSpec(
        "loop", "proc_periodic.exe", config::OperationType::NonReal,
        {{"args", "--exit-now 0"}, {"restart", "always"}, {"restart_delay_ms", "1"}, {"max_restarts", "3"}});
    ASSERT_TRUE(h.supervisor.start(h.launch(spec, 0)).ok());
    ASSERT_TRUE(h.waitUntil("loop", [](const hosts::ProcessInfo &p) { return p.exits == 4 && !p.restart_pending; }))
        << h.all();
    const auto info = h.info("loop");
    EXPECT_EQ(info.starts, 4u);
    EXPECT_EQ(info.restarts, 3u);
    EXPECT_EQ(info.crashes, 0u);
    EXPECT_EQ(info.failures, 0u);
    EXPECT_EQ(info.last_exit, "exited with status 0");
    EXPECT_TRUE(h.has("not restarted: max_restarts 3 reached")) << h.all();
    EXPECT_EQ(h.slot(0).generation, 4u);
}

TEST(ProcessRestart, CleanExitNotRestartedOnFailurePolicy) {
    Harness h;
    ASSERT_TRUE(h.supervisor
                    .start(h.launch(processSpec("fine", "proc_periodic.exe", config::OperationType::NonReal,
                                                {{"args", "--exit-now 0"}}),
                                    0))
                    .ok());
    ASSERT_TRUE(h.waitUntil("fine", [](const hosts::ProcessInfo &p) { return p.exits == 1; })) << h.all();
    EXPECT_FALSE(h.info("fine").restart_pending);
    EXPECT_TRUE(h.has("exited with status 0; not restarted (restart=on-failure)")) << h.all();
}

TEST(ProcessRestart, NonZeroExitIsAFailure) {
    Harness h;
    auto spec = processSpec("bad", "proc_periodic.exe", config::OperationType::Periodic,
                            {{"args", "--exit-at 1 3"}, {"max_restarts", "0"}});
    ASSERT_TRUE(h.supervisor.start(h.launch(spec, 0)).ok());
    ASSERT_TRUE(h.supervisor.waitReady(kLong).ok()) << h.all();
    release(h.slot(0), 1);
    ASSERT_TRUE(h.waitUntil("bad", [](const hosts::ProcessInfo &p) { return p.exits == 1; })) << h.all();
    const auto info = h.info("bad");
    EXPECT_EQ(info.failures, 1u);
    EXPECT_EQ(info.crashes, 0u);
    EXPECT_EQ(info.last_exit, "exited with status 3");
    EXPECT_TRUE(h.has("not restarted: max_restarts 0 reached")) << h.all();
}

TEST(ProcessStop, HangInItsPeriodTimesOutThenStopAllKillsIt) {
    Harness h;
    auto spec = processSpec("hang", "proc_periodic.exe", config::OperationType::Periodic, {{"args", "--hang-at 2"}});
    ASSERT_TRUE(h.supervisor.start(h.launch(spec, 3)).ok());
    ASSERT_TRUE(h.supervisor.waitReady(kLong).ok()) << h.all();
    indurop_process_slot &s = h.slot(3);
    ASSERT_TRUE(awaitDone(s, release(s, 1), kLong));
    const uint32_t seq = release(s, 2);
    ASSERT_TRUE(h.waitFor("[hang] hanging")) << h.all();
    EXPECT_FALSE(awaitDone(s, seq, 200 * kMs));  // the dispatcher's bounded wait times out
    const pid_t pid = h.info("hang").pid;
    h.supervisor.poll();
    EXPECT_TRUE(h.info("hang").running);  // a hang is the dispatcher's business, not a supervisor's
    EXPECT_EQ(s.pid, pid);
    EXPECT_EQ(stateOf(s), INDUROP_PROCESS_RUNNING);
    EXPECT_EQ(kill(pid, 0), 0);

    h.supervisor.stopAll(300 * kMs);  // it ignores SIGTERM: SIGKILL ends it
    const auto info = h.info("hang");
    EXPECT_FALSE(info.running);
    EXPECT_NE(info.last_exit.find("killed by SIGKILL"), std::string::npos) << info.last_exit;
    EXPECT_EQ(info.crashes, 0u);  // irpd killed it: not a crash
    EXPECT_EQ(info.restarts, 0u);
    EXPECT_TRUE(pidGone(pid));
}

TEST(ProcessStop, StopAllEndsEveryKindOfChild) {
    Harness h;
    ASSERT_TRUE(h.supervisor.start(h.launch(processSpec("p", "proc_periodic.exe"), 0)).ok());
    ASSERT_TRUE(
        h.supervisor
            .start(h.launch(
                processSpec("n", "proc_periodic.exe", config::OperationType::NonReal, {{"args", "--no-init"}}), 1))
            .ok());
    ASSERT_TRUE(h.supervisor.waitReady(kLong).ok()) << h.all();
    const pid_t p = h.info("p").pid, n = h.info("n").pid;
    h.supervisor.stopAll(1'000 * kMs);
    EXPECT_TRUE(pidGone(p));
    EXPECT_TRUE(pidGone(n));
    EXPECT_EQ(h.info("p").last_exit, "exited with status 0");             // left through waitPeriod() == -1
    EXPECT_NE(h.info("n").last_exit.find("SIGTERM"), std::string::npos);  // no handshake: SIGTERM
}

// ---- output -------------------------------------------------------------------------------------

long residentKiB() {
    std::ifstream status("/proc/self/status");
    std::string line;
    while (std::getline(status, line))
        if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
    return 0;
}

TEST(ProcessOutput, FloodIsDroppedAndReportedWithBoundedMemory) {
    std::size_t flood_lines = 0, longest = 0;
    bool cut_marked = false, drop_reported = false;
    const long rss_before = residentKiB();
    std::string instance = uniqueInstance();
    auto control = ControlSegment::create(instance, 1);
    ASSERT_TRUE(control.ok());
    {
        ProcessSupervisor supervisor([&](std::string_view line) {
            if (line.starts_with("[flood] ")) {
                ++flood_lines;
                longest = std::max(longest, line.size());
                cut_marked |= line.find("[line cut at 4096 bytes]") != std::string_view::npos;
            }
            drop_reported |= line.find("output lines (") != std::string_view::npos &&
                             line.find("dropped: more than 200 lines or 64 KiB per second") != std::string_view::npos;
        });
        ProcessLaunch l;
        l.spec = processSpec("flood", "proc_flood.exe", config::OperationType::NonReal,
                             {{"args", "--lines 100000 --long-line 10000"}});
        l.control_shm = control->name();
        ASSERT_TRUE(supervisor.start(l).ok());
        const int64_t deadline = nowNs() + 60'000 * kMs;
        while (nowNs() < deadline && supervisor.process("flood")->exits == 0) {
            supervisor.poll();
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
        const auto info = *supervisor.process("flood");
        ASSERT_EQ(info.exits, 1u);
        EXPECT_EQ(info.last_exit, "exited with status 0");
        // Every line is either forwarded or counted as dropped.
        EXPECT_EQ(info.lines + info.dropped_lines, 100001u);
        EXPECT_EQ(info.lines, flood_lines);
        EXPECT_GT(info.dropped_lines, 0u);
        EXPECT_LT(info.lines, 100001u);
    }
    EXPECT_TRUE(drop_reported);
    EXPECT_TRUE(cut_marked);
    EXPECT_LE(longest, std::string("[flood] ").size() + 4096 + std::string(" [line cut at 4096 bytes]").size());
    // 100 000 lines never piled up in irpd (they are > 1.2 MB; allow the allocator its slack).
    EXPECT_LT(residentKiB() - rss_before, 8 * 1024);
}

// ---- children never outlive irpd ----------------------------------------------------------------

TEST(ProcessParentDeath, ChildrenDieWithTheirSupervisor) {
    int fds[2];
    ASSERT_EQ(pipe(fds), 0);
    const std::string instance = uniqueInstance();
    const pid_t helper = fork();
    ASSERT_GE(helper, 0);
    if (helper == 0) {
        // The helper plays irpd: control segment, supervisor, one process; then waits to be killed.
        close(fds[0]);
        auto control = ControlSegment::create(instance, 1);
        if (!control) _exit(3);
        ProcessSupervisor supervisor([](std::string_view) {});
        ProcessLaunch l;
        l.spec = processSpec("orphan", "proc_periodic.exe");
        l.control_shm = control->name();
        if (!supervisor.start(l).ok() || !supervisor.waitReady(kLong).ok()) _exit(4);
        const pid_t child = supervisor.process("orphan")->pid;
        if (write(fds[1], &child, sizeof child) != sizeof child) _exit(5);
        for (;;) pause();
    }
    close(fds[1]);
    pid_t child = 0;
    pollfd pfd{fds[0], POLLIN, 0};
    ASSERT_EQ(::poll(&pfd, 1, 20'000), 1);
    ASSERT_EQ(read(fds[0], &child, sizeof child), static_cast<ssize_t>(sizeof child));
    close(fds[0]);
    ASSERT_GT(child, 0);
    EXPECT_FALSE(pidGone(child));

    ASSERT_EQ(kill(helper, SIGKILL), 0);
    int status = 0;
    ASSERT_EQ(waitpid(helper, &status, 0), helper);
    const int64_t deadline = nowNs() + kLong;
    while (!pidGone(child) && nowNs() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    EXPECT_TRUE(pidGone(child)) << "process module pid " << child << " outlived its supervisor";
    osal::SharedMemory::unlink(ControlSegment::shmName(instance));
}

// ---- refusals at start --------------------------------------------------------------------------

std::string startError(config::ModuleSpec spec, uint32_t slot = 0) {
    Harness h(2);
    Status s = h.supervisor.start(h.launch(std::move(spec), slot));
    return s.ok() ? std::string("(started)") : s.error().message;
}

TEST(ProcessRefusal, MissingFile) {
    auto spec = processSpec("ghost", "no_such.exe");
    EXPECT_EQ(startError(spec), "sets/test/module.xml:9: module 'ghost': <filename> ./no_such.exe -> " +
                                    fixturePath("no_such.exe") + " does not exist");
}

TEST(ProcessRefusal, NotExecutable) {
    const std::string e = startError(processSpec("plain", "not_executable.exe"));
    EXPECT_EQ(e.rfind("sets/test/module.xml:9: module 'plain': <filename> ./not_executable.exe -> " +
                          fixturePath("not_executable.exe") + " is not executable",
                      0),
              0u)
        << e;
}

// Bad properties (restart=sometimes, ...) never get here: module.xml's parser refuses them
// (tests/cpp/test_process_properties.cpp).

TEST(ProcessRefusal, SlotOutOfRange) {
    const std::string e = startError(processSpec("s", "proc_periodic.exe"), 7);
    EXPECT_NE(e.find("module 's': control slot 7 out of range (2 slots"), std::string::npos) << e;
}

TEST(ProcessRefusal, SameSlotTwice) {
    Harness h;
    ASSERT_TRUE(h.supervisor.start(h.launch(processSpec("first", "proc_periodic.exe"), 0)).ok());
    Status s = h.supervisor.start(h.launch(processSpec("second", "proc_periodic.exe"), 0));
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("already started (as 'first' in slot 0)"), std::string::npos) << s.error().message;
    // The same module in another slot is a hot reload's replacement: allowed.
    EXPECT_TRUE(h.supervisor.start(h.launch(processSpec("first", "proc_periodic.exe"), 1)).ok());
}

// ---- the process side's own checks --------------------------------------------------------------

TEST(ProcessInit, NotStartedByIrpd) {
    ASSERT_EQ(std::getenv("INDUROP_CTL"), nullptr);
    EXPECT_EQ(irp::initPeriodExe(), -1);
    EXPECT_EQ(irp::waitPeriod(), -1);  // at once
}

TEST(ProcessInit, RefusesASlotOutOfRange) {
    testing_support::TempDir dir;
    const std::string instance = uniqueInstance();
    auto control = ControlSegment::create(instance, 2);
    ASSERT_TRUE(control.ok());
    setenv("INDUROP_CTL", control->name().c_str(), 1);
    setenv("INDUROP_SLOT", "9", 1);
    testing_support::Process p({fixturePath("proc_periodic.exe")}, dir.path);
    unsetenv("INDUROP_CTL");
    unsetenv("INDUROP_SLOT");
    EXPECT_EQ(p.wait(), 2);
    EXPECT_NE(p.err().find("INDUROP_SLOT 9 is out of range: control segment " + control->name() + " has 2 slots"),
              std::string::npos)
        << p.err();
}

TEST(ProcessInit, RefusesAForeignSegment) {
    testing_support::TempDir dir;
    Variables vars;  // a variables segment is not a control segment
    setenv("INDUROP_CTL", vars.name().c_str(), 1);
    setenv("INDUROP_SLOT", "0", 1);
    testing_support::Process p({fixturePath("proc_periodic.exe")}, dir.path);
    unsetenv("INDUROP_CTL");
    unsetenv("INDUROP_SLOT");
    EXPECT_EQ(p.wait(), 2);
    EXPECT_NE(p.err().find("not an indurop control segment (bad magic)"), std::string::npos) << p.err();
}

TEST(ProcessInit, LayoutMismatchExits78WithBothHashes) {
    Harness h;
    Variables vars;
    auto other = variables::readLayout(OTHER_LAYOUT);
    ASSERT_TRUE(other.ok());
    ASSERT_TRUE(h.supervisor.start(h.launch(processSpec("stale", "proc_other_layout.exe"), 0, vars.name())).ok());
    Status ready = h.supervisor.waitReady(kLong);
    ASSERT_FALSE(ready.ok());
    EXPECT_NE(ready.error().message.find("'stale' exited with status 78 before it was ready"), std::string::npos)
        << ready.error().message;
    EXPECT_TRUE(h.has("built against shared-variable layout " + other->hash + ", which is neither the layout " +
                      std::string(vars.segment->hash())))
        << h.all();
    EXPECT_FALSE(h.has("initPeriodExe returned")) << h.all();
    EXPECT_TRUE(h.has("not restarted: it refused the running shared-variable layout")) << h.all();
    EXPECT_FALSE(h.info("stale").restart_pending);
}

TEST(ProcessInit, LayoutUsedButNoSegmentExits78) {
    Harness h;
    ASSERT_TRUE(h.supervisor.start(h.launch(processSpec("novars", "proc_other_layout.exe"), 0)).ok());
    ASSERT_FALSE(h.supervisor.waitReady(kLong).ok());
    EXPECT_EQ(h.info("novars").last_exit, "exited with status 78");
    EXPECT_TRUE(h.has("but irpd runs no shared variables (the set declares no <layout>)")) << h.all();
}

// ---- shared variables by path, in this process --------------------------------------------------

TEST(ChannelPaths, NoSegmentIsAnErrorNotACrash) {
    channel::Handle handle;
    double y = 0;
    EXPECT_EQ(channel::connect(handle), -1);
    EXPECT_NE(std::string(channel::lastError(handle)).find("no shared-variable segment"), std::string::npos);
    EXPECT_EQ(read(handle, "joint[1].y", sizeof y, &y), -1);
    EXPECT_NE(std::string(channel::lastError(handle)).find("INDUROP_SHM is not set"), std::string::npos)
        << channel::lastError(handle);
    EXPECT_EQ(write(handle, "joint[1].y", sizeof y, &y), -1);
}

TEST(ChannelPaths, ResolveEveryKindOfPath) {
    Variables vars;
    channel::Handle handle;
    ASSERT_EQ(channel::connect(handle), 0) << channel::lastError(handle);
    EXPECT_STREQ(channel::lastError(handle), "");

    // A leaf, written by path, read through the generated global and back by path.
    double y = 12.25;
    EXPECT_EQ(write(handle, "joint[1].y", sizeof y, &y), 8);
    EXPECT_EQ(static_cast<double>(joint[1].y), 12.25);
    joint[1].y = -3.5;
    EXPECT_EQ(read(handle, "joint[1].y", sizeof y, &y), 8);
    EXPECT_EQ(y, -3.5);

    // A whole struct element, a whole array.
    joint_t j{1, 2, 3};
    EXPECT_EQ(write(handle, "joint[3]", sizeof j, &j), 24);
    EXPECT_EQ(static_cast<double>(joint[3].z), 3);
    joint_t all[4];
    EXPECT_EQ(read(handle, "joint", sizeof all, all), 96);
    EXPECT_EQ(all[3].y, 2);
    EXPECT_EQ(all[1].y, -3.5);

    // Two dimensions: an element and a row.
    int32_t v = 42;
    EXPECT_EQ(write(handle, "m[1][2]", sizeof v, &v), 4);
    EXPECT_EQ(static_cast<int32_t>(m[1][2]), 42);
    int32_t row[3];
    EXPECT_EQ(read(handle, "m[1]", sizeof row, row), 12);
    EXPECT_EQ(row[2], 42);

    // Namespaced: full path; nested struct members; a struct inside an array element.
    uint32_t tick = 7;
    EXPECT_EQ(write(handle, "test.cell.tick", sizeof tick, &tick), 4);
    EXPECT_EQ(static_cast<uint32_t>(test::cell::tick), 7u);
    float f = 0.5f;
    EXPECT_EQ(write(handle, "test.cell.rec[1].inner.v[2]", sizeof f, &f), 4);
    EXPECT_EQ(static_cast<float>(test::cell::rec[1].inner.v[2]), 0.5f);
    int16_t a = -9;
    EXPECT_EQ(write(handle, "rec[0].a", sizeof a, &a), 2);  // no namespace: only test.cell has rec
    EXPECT_EQ(static_cast<int16_t>(test::cell::rec[0].a), -9);
    float inner[3];
    EXPECT_EQ(read(handle, "test.cell.rec[1].inner", sizeof inner, inner), 12);
    EXPECT_EQ(inner[2], 0.5f);

    // A handle that was never connected connects on first use.
    channel::Handle fresh;
    EXPECT_EQ(read(fresh, "test.cell.tick", sizeof tick, &tick), 4);
    EXPECT_EQ(tick, 7u);
}

struct BadPath {
    const char *name;  // the test's name
    const char *path;
    std::size_t size;
    const char *message;
};

class ChannelBadPath : public ::testing::TestWithParam<BadPath> {};

TEST_P(ChannelBadPath, IsMinusOneWithAReason) {
    Variables vars;
    channel::Handle handle;
    const BadPath &bad = GetParam();
    char buffer[128] = {};
    EXPECT_EQ(read(handle, bad.path, bad.size, buffer), -1);
    EXPECT_NE(std::string(channel::lastError(handle)).find(bad.message), std::string::npos)
        << channel::lastError(handle);
    EXPECT_EQ(write(handle, bad.path, bad.size, buffer), -1);
    EXPECT_NE(std::string(channel::lastError(handle)).find(bad.message), std::string::npos)
        << channel::lastError(handle);
    // The handle still works afterwards.
    double y;
    EXPECT_EQ(read(handle, "joint[0].x", sizeof y, &y), 8);
    EXPECT_STREQ(channel::lastError(handle), "");
}

INSTANTIATE_TEST_SUITE_P(
    Paths, ChannelBadPath,
    ::testing::Values(BadPath{"IndexOutOfRange", "joint[4].y", 8,
                              "index 4 out of range, 'joint' has 4 elements (0..3)"},
                      BadPath{"NoSuchMember", "joint[1].w", 8, "'joint[1]' has no member w (members: x, y, z)"},
                      BadPath{"SizeOfALeaf", "joint[1].y", 4, "size 4 given for 'joint[1].y', which is 8 bytes"},
                      BadPath{"SizeOfAWholeArray", "joint", 24, "size 24 given for 'joint', which is 96 bytes"},
                      BadPath{"MemberOfAnArray", "joint.y", 8, "'joint' is an array of 4: index it before .y"},
                      BadPath{"MemberOfAScalar", "joint[1].y.z", 8, "'joint[1].y' is a double, it has no member z"},
                      BadPath{"IndexOfAScalar", "joint[1].y[0]", 8, "'joint[1].y' is not an array"},
                      BadPath{"IndexNotANumber", "joint[x].y", 8, "index 'x' is not a decimal number"},
                      BadPath{"NegativeIndex", "joint[-1].y", 8, "index '-1' is not a decimal number"},
                      BadPath{"UnclosedBracket", "joint[1", 8, "'[' without ']'"},
                      BadPath{"EmptyMember", "joint[1]..y", 8, "empty member name"},
                      BadPath{"TextAfterIndex", "joint[1]y", 8, "unexpected 'y' after 'joint[1]'"},
                      BadPath{"OuterIndexOutOfRange", "m[2][0]", 4, "index 2 out of range, 'm' has 2 elements"},
                      BadPath{"InnerIndexOutOfRange", "m[1][3]", 4, "index 3 out of range, 'm[1]' has 3 elements"},
                      BadPath{"UnknownVariable", "nosuch", 4, "no shared variable matches path 'nosuch'"},
                      BadPath{"PrefixOfAVariable", "jointx[1].y", 8, "no shared variable matches path 'jointx[1].y'"},
                      BadPath{"AmbiguousWithoutNamespace", "tick", 4,
                              "'tick' is ambiguous: tick is in several namespaces (test.cell.tick, test.other.tick)"},
                      BadPath{"NamespacedIndexOutOfRange", "test.cell.rec[2]", 16, "index 2 out of range"},
                      BadPath{"EmptyPath", "", 4, "empty path"}),
    [](const ::testing::TestParamInfo<BadPath> &info) { return std::string(info.param.name); });

TEST(ChannelPaths, NullArgumentsAreErrors) {
    Variables vars;
    channel::Handle handle;
    double y;
    EXPECT_EQ(read(handle, nullptr, sizeof y, &y), -1);
    EXPECT_STREQ(channel::lastError(handle), "path is null");
    EXPECT_EQ(read(handle, "joint[1].y", sizeof y, nullptr), -1);
    EXPECT_NE(std::string(channel::lastError(handle)).find("destination is null"), std::string::npos);
    EXPECT_EQ(write(handle, "joint[1].y", sizeof y, nullptr), -1);
    const std::string huge(5000, 'a');
    EXPECT_EQ(read(handle, huge.c_str(), sizeof y, &y), -1);
    EXPECT_NE(std::string(channel::lastError(handle)).find("path longer than 1024"), std::string::npos);
}

TEST(ChannelPaths, AnotherSegmentDropsTheCache) {
    channel::Handle handle;
    double y = 1.5;
    {
        Variables vars;
        ASSERT_EQ(write(handle, "joint[2].y", sizeof y, &y), 8);
    }
    EXPECT_EQ(read(handle, "joint[2].y", sizeof y, &y), -1);  // the segment is gone
    Variables again;
    EXPECT_EQ(read(handle, "joint[2].y", sizeof y, &y), 8);
    EXPECT_EQ(y, 0);  // a new, zeroed segment
}

// ---- shared variables by path, in a process module ----------------------------------------------

TEST(ProcessChannel, ReadAndWriteByPathInAChild) {
    Harness h;
    Variables vars;
    joint[1].y = 21.5;
    ASSERT_TRUE(h.supervisor.start(h.launch(processSpec("vars", "proc_vars.exe"), 0, vars.name())).ok());
    ASSERT_TRUE(h.supervisor.waitReady(kLong).ok()) << h.all();
    indurop_process_slot &s = h.slot(0);
    ASSERT_TRUE(awaitDone(s, release(s, 11), kLong)) << h.all();
    EXPECT_EQ(static_cast<double>(joint[2].x), 43);
    EXPECT_EQ(static_cast<uint32_t>(test::cell::tick), 11u);
    ASSERT_TRUE(h.waitFor("[vars] done")) << h.all();
    EXPECT_TRUE(h.has("[vars] connect=0")) << h.all();
    EXPECT_TRUE(h.has("[vars] read joint[1].y rc=8 value=21.5 global=21.5")) << h.all();
    EXPECT_TRUE(h.has("[vars] write joint[2].x rc=8")) << h.all();
    EXPECT_TRUE(h.has("[vars] write tick rc=4")) << h.all();
    EXPECT_TRUE(h.has("[vars] bad path rc=-1: path 'joint[1].w': 'joint[1]' has no member w")) << h.all();
    EXPECT_TRUE(h.has("[vars] bad index rc=-1: path 'joint[4].y': index 4 out of range")) << h.all();
    EXPECT_TRUE(h.has("[vars] bad size rc=-1: size 4 given for 'joint[1].y', which is 8 bytes")) << h.all();

    joint[1].y = -1;
    ASSERT_TRUE(awaitDone(s, release(s, 12), kLong)) << h.all();
    EXPECT_EQ(static_cast<double>(joint[2].x), -2);
    EXPECT_EQ(static_cast<uint32_t>(test::cell::tick), 12u);
}

// ---- the paper's Figure 8 -----------------------------------------------------------------------

TEST(PaperFigure8, SporadicProcessReleasedThroughItsSlotReadsJoint1Y) {
    Harness h;
    Variables vars;
    joint[1].y = 181.5;  // an event for its condition()
    ASSERT_TRUE(h.supervisor
                    .start(h.launch(processSpec("fig8", "fig8_sporadic_process.exe", config::OperationType::Sporadic),
                                    0, vars.name()))
                    .ok());
    ASSERT_TRUE(h.supervisor.waitReady(kLong).ok()) << h.all();
    indurop_process_slot &s = h.slot(0);
    EXPECT_EQ(s.kind, 1u);
    ASSERT_TRUE(awaitDone(s, release(s, 1), kLong)) << h.all();
    EXPECT_TRUE(h.waitFor("[fig8] fig8 read joint[1].y rc=8 value=181.5")) << h.all();
    joint[1].y = 90;
    ASSERT_TRUE(awaitDone(s, release(s, 2), kLong)) << h.all();
    EXPECT_TRUE(h.waitFor("[fig8] fig8 read joint[1].y rc=8 value=90")) << h.all();

    // Its loop ignores waitPeriod()'s -1; the next call ends it, cleanly.
    h.supervisor.stopAll(5'000 * kMs);
    EXPECT_EQ(h.info("fig8").last_exit, "exited with status 0");
    EXPECT_EQ(h.info("fig8").crashes, 0u);
}
