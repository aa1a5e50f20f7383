// test_faults.cpp -- faults irpd survives or contains, each injected into a running irpd
// (docs/faults.md): a thread module that overruns (the watchdog's stop drives safe outputs while
// it is still stuck, disable takes it out), one that throws, and a periodic process module that
// segfaults, exits, floods its output or hangs.  Each test checks that irpd still answers, that
// the rest of the set still runs, and that the event names the module.  The device side, on the
// plc-robot cell with the drive simulator started apart: a stop drives the drives' controlwords
// to 0 over Modbus while the faulty module is still stuck, irpd killed -9 leaves the drives to
// their own comm timeout, which quick-stops them, and the drives that stop answering make the PLC
// raise its alarm 8 with its text (docs/alarms.md), cleared once they are back and the error
// reset.  No timing figure is asserted here; tests/bench/faults.py measures them.
#include "osal/shm.hpp"
#include "support/alarm_ring.hpp"
#include "support/control_client.hpp"
#include "support/drivesim.hpp"
#include "support/irpd.hpp"
#include "support/subprocess.hpp"

#include <gtest/gtest.h>

#include <dlfcn.h>
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <thread>
#include <tuple>
#include <utility>

using nlohmann::json;
using testing_support::Client;
using testing_support::kIrpd;
using testing_support::Process;
using testing_support::readFile;
using testing_support::TempDir;
using testing_support::uniqueInstance;
namespace fs = std::filesystem;

namespace {

const fs::path kModules = FIXTURE_MODULES;
const std::string kProcess = std::string(FIXTURE_PROCESSES) + "/proc_periodic.exe";

std::string thread(const std::string &name, const std::string &file, int64_t period_ns, int priority,
                   const std::string &extra = "") {
    return "  <module><name>" + name + "</name><filename>" + file +
           "</filename><moduletype>thread</moduletype><operationtype>periodic</operationtype><period>" +
           std::to_string(period_ns) + "</period><priority>" + std::to_string(priority) + "</priority>" + extra +
           "</module>\n";
}

std::string process(const std::string &name, const std::string &properties, const std::string &extra = "") {
    return "  <module><name>" + name + "</name><filename>" + kProcess +
           "</filename><moduletype>process</moduletype><operationtype>periodic</operationtype>"
           "<period>2000000</period><priority>5</priority>" +
           extra + "<property>" + properties + "</property></module>\n";
}

std::string value(const std::string &name, const std::string &v) {
    return "<value name=\"" + name + "\">" + v + "</value>";
}

// irpd on `folder`/module.xml with its control socket and module cache there; returns it running
// and a client past the hello.
std::pair<std::unique_ptr<Process>, std::unique_ptr<Client>>
startIrpd(const fs::path &folder, const std::string &socket, const std::string &instance = uniqueInstance()) {
    auto irpd = std::make_unique<Process>(std::vector<std::string>{kIrpd, "--config", (folder / "module.xml").string(),
                                                                   "--control-socket", socket, "--instance", instance,
                                                                   "--module-cache", (folder / "cache").string()},
                                          folder);
    EXPECT_TRUE(irpd->waitForErr("irpd: running")) << irpd->err();
    auto client = std::make_unique<Client>(socket, 60);
    EXPECT_FALSE(client->readLine().empty());  // the hello
    return {std::move(irpd), std::move(client)};
}

// irpd on a set written into a scratch folder, with its control socket.  Every set has `keep`
// (a counter, 1 ms) beside the module under test: "the rest of the set".  "@DIR@" in the body
// stands for the scratch folder.
struct Cell {
    TempDir dir;
    std::string socket = (dir.path / "irpd.sock").string();
    std::unique_ptr<Process> irpd;
    std::unique_ptr<Client> client;

    explicit Cell(std::string body, const std::string &root_extra = "") {
        for (std::size_t at; (at = body.find("@DIR@")) != std::string::npos;) body.replace(at, 5, dir.path.string());
        fs::copy_file(kModules / "counter_v1.so", dir.path / "keep.so");
        fs::copy_file(kModules / "overrun.so", dir.path / "overrun.so");
        fs::copy_file(kModules / "throws_in_run.so", dir.path / "throws.so");
        std::ofstream(dir.path / "module.xml")
            << "<root>\n" + root_extra +
                   thread("keep", "keep.so", 1'000'000, 1,
                          "<property>" + value("journal", journal("keep")) + "</property>") +
                   body + "</root>\n";
        std::tie(irpd, client) = startIrpd(dir.path, socket);
    }
    ~Cell() {
        client.reset();
        kill(irpd->pid(), SIGTERM);
        EXPECT_EQ(irpd->wait(std::chrono::seconds(10)), 0) << irpd->err();
    }
    std::string journal(const std::string &name) const { return (dir.path / (name + ".log")).string(); }
    std::string log(const std::string &name) const { return readFile(journal(name)); }
    json result(const json &request) {
        json answer = client->request(request);
        EXPECT_TRUE(answer.value("ok", false)) << request.dump() << " -> " << answer.dump();
        return answer.value("result", json());
    }
    json module(const std::string &name) {
        for (const json &m : result({{"cmd", "modules"}}))
            if (m["name"] == name) return m;
        return json();
    }
    uint64_t runs(const std::string &name) { return module(name).value("runs", uint64_t{0}); }
    // The events of `kind` about `module`.
    std::vector<json> events(const std::string &kind, const std::string &module) {
        std::vector<json> found;
        const json all = result({{"cmd", "events"}, {"limit", 4096}});
        for (const json &e : all["events"])
            if (e["kind"] == kind && e["module"] == module) found.push_back(e);
        return found;
    }
    // Polls `done` every 20 ms for up to 20 s.
    bool waitUntil(const std::function<bool()> &done) {
        const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
        while (std::chrono::steady_clock::now() < end) {
            if (done()) return true;
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        return false;
    }
    // The rest of the set runs: keep's runs grow.
    bool keepRuns() {
        const uint64_t before = runs("keep");
        return waitUntil([&] { return runs("keep") > before + 20; });
    }
};

bool contains(const std::string &text, const std::string &part) { return text.find(part) != std::string::npos; }

}  // namespace

// ---- a thread module that overruns ------------------------------------------------------------

std::string overrun(const std::string &action, const std::string &properties, const std::string &executor = "") {
    return thread("stuck", "overrun.so", 2'000'000, 2,
                  executor + "<on_overrun>" + action + "</on_overrun><overrun_limit>2000000</overrun_limit><property>" +
                      value("journal", "@DIR@/stuck.log") + properties + "</property>");
}

TEST(OverrunWatchdog, StopDrivesSafeOutputsWhileTheModuleIsStillStuckAndHaltsTheSet) {
    // `stuck` spins in its 20th run until its safe_outputs() is called (at most 10 s).
    Cell cell(overrun("stop", value("hang_at", "20")));
    ASSERT_TRUE(cell.waitUntil([&] { return contains(cell.log("stuck"), "overran"); })) << cell.irpd->err();
    // safe_outputs() came while run 20 was still spinning, and that is what ended the spin.
    const std::string log = cell.log("stuck");
    EXPECT_EQ(log.substr(0, log.find("run 20 overran")), "start\nsafe_outputs during run 20\n") << log;
    const auto seen = cell.events("overrun", "stuck");
    ASSERT_FALSE(seen.empty()) << cell.result({{"cmd", "events"}}).dump();
    EXPECT_TRUE(contains(seen[0]["message"], "still running")) << seen[0].dump();
    EXPECT_TRUE(contains(seen[0]["message"], "on_overrun=stop")) << seen[0].dump();
    const auto stopped = cell.events("stopped", "stuck");
    ASSERT_EQ(stopped.size(), 1u);
    EXPECT_TRUE(contains(stopped[0]["message"], "outputs of 1 module(s) driven to safe values")) << stopped[0].dump();
    const json status = cell.result({{"cmd", "status"}});
    ASSERT_TRUE(status["stopped_by_fault"].is_string()) << status.dump();
    EXPECT_TRUE(contains(status["stopped_by_fault"], "module 'stuck'")) << status.dump();
    // Halted: keep runs no more, while irpd still answers; a reload is refused until a restart.
    const uint64_t keep = cell.runs("keep");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    EXPECT_EQ(cell.runs("keep"), keep);
    EXPECT_EQ(cell.module("keep").value("state", ""), "stopped");
    json reload = cell.client->request({{"cmd", "load"}, {"config", (cell.dir.path / "module.xml").string()}});
    EXPECT_FALSE(reload.value("ok", true));
    EXPECT_TRUE(contains(reload["error"].value("message", ""), "stopped by a fault")) << reload.dump();
}

TEST(OverrunWatchdog, DisableTakesTheModuleOutAndTheRestRunsOn) {
    // On its own executor: keep's executor is never held up by it.
    Cell cell(overrun("disable", value("hang_at", "10") + value("hang_ms", "30"), "<executor>slow</executor>"),
              "<executor><name>slow</name></executor>\n");
    ASSERT_TRUE(cell.waitUntil([&] { return cell.module("stuck").value("state", "") == "disabled"; }));
    // A run's count reaches the stats block when irpd's stats thread folds it (within ~1 ms of the
    // run, docs/scheduler.md), the module's state at once.
    ASSERT_TRUE(cell.waitUntil([&] { return cell.runs("stuck") >= 10u; }));
    EXPECT_EQ(cell.runs("stuck"), 10u);
    EXPECT_TRUE(cell.keepRuns());
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    EXPECT_EQ(cell.runs("stuck"), 10u);
    bool disabled_event = false;
    for (const json &e : cell.events("overrun", "stuck")) disabled_event |= contains(e["message"], "disabled");
    EXPECT_TRUE(disabled_event);
    EXPECT_TRUE(cell.result({{"cmd", "status"}})["stopped_by_fault"].is_null());
    // It does not poll irp::runAbortRequested(): its run went on to its end, and nothing threw.
    EXPECT_TRUE(contains(cell.log("stuck"), "run 10 overran")) << cell.log("stuck");
    EXPECT_TRUE(cell.events("fault", "stuck").empty());
}

// An endless loop that polls irp::runAbortRequested() (as Structured Text's loops do) is ended by
// the watchdog: the flag turns true once the run passed its limit, the module throws, it is
// disabled with a `fault` event carrying its text, and the executor it held -- keep's own, here --
// runs on.  Without the request the run would spin for a minute.
TEST(OverrunWatchdog, AnEndlessLoopThatPollsRunAbortRequestedIsEndedAndNamedWhileTheRestRunsOn) {
    Cell cell(overrun("disable", value("hang_at", "10") + value("hang_ms", "60000") + value("poll_abort", "1")));
    ASSERT_TRUE(cell.waitUntil([&] { return !cell.events("fault", "stuck").empty(); })) << cell.log("stuck");
    const json fault = cell.events("fault", "stuck")[0];
    EXPECT_TRUE(contains(fault["message"], "run(): overrun.cpp: endless loop? run 10 ended at the watchdog's request"))
        << fault.dump();
    EXPECT_TRUE(contains(cell.log("stuck"), "run 10 asked to end after")) << cell.log("stuck");
    EXPECT_EQ(cell.module("stuck").value("state", ""), "disabled");
    EXPECT_EQ(cell.module("stuck").value("errors", 0), 1);
    const auto seen = cell.events("overrun", "stuck");
    ASSERT_FALSE(seen.empty());
    EXPECT_TRUE(contains(seen[0]["message"], "still running")) << seen[0].dump();
    EXPECT_TRUE(contains(seen[0]["message"], "asked to end")) << seen[0].dump();
    EXPECT_TRUE(cell.keepRuns());
    ASSERT_TRUE(cell.waitUntil([&] { return cell.runs("stuck") >= 10u; }));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    EXPECT_EQ(cell.runs("stuck"), 10u);
    EXPECT_TRUE(cell.result({{"cmd", "status"}})["stopped_by_fault"].is_null());
}

// An executor that a hot reload adds is watched as well: its module's overrun comes back as an
// event (the watchdog drains the new executor's outcomes) and its action is taken.
TEST(OverrunWatchdog, AnExecutorAddedOnlineIsWatched) {
    Cell cell("");
    std::string body = overrun("disable", value("hang_at", "10") + value("hang_ms", "30"), "<executor>slow</executor>");
    for (std::size_t at; (at = body.find("@DIR@")) != std::string::npos;) body.replace(at, 5, cell.dir.path.string());
    std::ofstream(cell.dir.path / "slow.xml")
        << "<root>\n  <executor><name>slow</name></executor>\n" +
               thread("keep", "keep.so", 1'000'000, 1,
                      "<property>" + value("journal", cell.journal("keep")) + "</property>") +
               body + "</root>\n";
    const json report = cell.result({{"cmd", "load"}, {"config", (cell.dir.path / "slow.xml").string()}});
    EXPECT_EQ(report["kept"], json({"keep"})) << report.dump();
    ASSERT_TRUE(cell.waitUntil([&] { return cell.module("stuck").value("state", "") == "disabled"; }));
    ASSERT_TRUE(cell.waitUntil([&] {
        for (const json &e : cell.events("overrun", "stuck"))
            if (contains(e["message"], "disabled")) return true;
        return false;
    })) << cell.irpd->err();
    EXPECT_TRUE(cell.keepRuns());
}

TEST(OverrunWatchdog, SkipDropsTheMissedRunsAndTheModuleGoesOn) {
    Cell cell(overrun("skip", value("hang_at", "10") + value("hang_ms", "30")));
    ASSERT_TRUE(cell.waitUntil([&] { return cell.runs("stuck") > 30; }));
    const json stuck = cell.module("stuck");
    EXPECT_GE(stuck.value("skipped", 0), 14);  // 30 ms of its 2 ms periods, less the one it was in
    EXPECT_EQ(stuck.value("overruns", 0), 1);
    EXPECT_TRUE(cell.keepRuns());
    EXPECT_FALSE(cell.events("overrun", "stuck").empty());
}

TEST(OverrunWatchdog, WarnOnlyReportsIt) {
    // It polls irp::runAbortRequested(), which stays false under warn: its run goes on to its end.
    Cell cell(overrun("warn", value("hang_at", "10") + value("hang_ms", "10") + value("poll_abort", "1")));
    ASSERT_TRUE(cell.waitUntil([&] { return !cell.events("overrun", "stuck").empty(); }));
    ASSERT_TRUE(cell.waitUntil([&] { return cell.runs("stuck") > 30; }));
    EXPECT_EQ(cell.module("stuck").value("skipped", -1), 0);
    EXPECT_EQ(cell.module("stuck").value("overruns", 0), 1);
    EXPECT_TRUE(cell.keepRuns());
    EXPECT_TRUE(contains(cell.log("stuck"), "run 10 overran")) << cell.log("stuck");
    EXPECT_EQ(cell.module("stuck").value("state", ""), "running");
}

// ---- a thread module that throws --------------------------------------------------------------

TEST(ThreadFault, AThrowFromRunDisablesThatModuleOnlyAndIsAnEvent) {
    Cell cell(thread("throws", "throws.so", 2'000'000, 2));
    ASSERT_TRUE(cell.waitUntil([&] { return !cell.events("fault", "throws").empty(); }));
    EXPECT_EQ(cell.module("throws").value("state", ""), "disabled");
    EXPECT_EQ(cell.module("throws").value("errors", 0), 1);
    EXPECT_EQ(cell.runs("throws"), 3u);
    EXPECT_TRUE(cell.keepRuns());
    EXPECT_TRUE(contains(cell.irpd->out() + cell.irpd->err(), "division by zero in the controller"));
    // The event carries what it threw.
    const json fault = cell.events("fault", "throws")[0];
    EXPECT_TRUE(contains(fault["message"], "threw from run(): division by zero in the controller")) << fault.dump();
}

// ---- a periodic process module that segfaults, exits, floods or hangs ------------------------

TEST(ProcessFault, ASegfaultIsLoggedAndRestartedWhileTheRestRunsOn) {
    Cell cell(process("p", value("args", "--crash-at 5") + value("restart_delay_ms", "20")));
    ASSERT_TRUE(cell.waitUntil([&] { return !cell.events("process_restart", "p").empty(); })) << cell.irpd->out();
    const auto exits = cell.events("process_exit", "p");
    ASSERT_FALSE(exits.empty());
    EXPECT_TRUE(contains(exits[0]["message"], "SIGSEGV")) << exits[0].dump();
    EXPECT_TRUE(cell.keepRuns());
    const uint64_t p = cell.runs("p");
    EXPECT_TRUE(cell.waitUntil([&] { return cell.runs("p") > p; }));  // the restarted process runs
}

TEST(ProcessFault, AnExitIsLoggedAndRestartedWhileTheRestRunsOn) {
    Cell cell(process("p", value("args", "--exit-at 5 3") + value("restart_delay_ms", "20")));
    ASSERT_TRUE(cell.waitUntil([&] { return !cell.events("process_restart", "p").empty(); })) << cell.irpd->out();
    EXPECT_TRUE(contains(cell.events("process_exit", "p")[0]["message"], "status 3"));
    EXPECT_TRUE(cell.keepRuns());
}

TEST(ProcessFault, AFloodOfOutputIsCutAndReportedWhileTheRestRunsOn) {
    Cell cell(process("p", value("args", "--flood-at 5 200000")));
    ASSERT_TRUE(cell.waitUntil([&] { return !cell.events("process_output_dropped", "p").empty(); }))
        << cell.irpd->err();
    EXPECT_TRUE(cell.keepRuns());
    const uint64_t p = cell.runs("p");
    EXPECT_TRUE(cell.waitUntil([&] { return cell.runs("p") > p; }));  // it goes on after its flood
    EXPECT_TRUE(cell.events("process_exit", "p").empty());
}

TEST(ProcessFault, AHangIsDetectedKilledAndRestartedWithOnOverrunRestart) {
    Cell cell(process("p", value("args", "--hang-at 5") + value("restart_delay_ms", "20"),
                      "<on_overrun>restart</on_overrun><overrun_limit>2000000</overrun_limit>"));
    ASSERT_TRUE(cell.waitUntil([&] { return !cell.events("process_restart", "p").empty(); })) << cell.irpd->out();
    const auto hangs = cell.events("process_hang", "p");
    ASSERT_FALSE(hangs.empty());
    EXPECT_TRUE(contains(hangs[0]["message"], "killed")) << hangs[0].dump();
    EXPECT_TRUE(contains(cell.events("process_exit", "p")[0]["message"], "SIGKILL"));
    EXPECT_TRUE(cell.keepRuns());
    const uint64_t p = cell.runs("p");
    EXPECT_TRUE(cell.waitUntil([&] { return cell.runs("p") > p; }));
}

// Without <on_overrun> nobody acts on a hang: the dispatcher's wait for the process's done word
// ends at the end of the basic period (the overrun watchdog wakes it, docs/process-modules.md), it
// is counted, its later releases are missed, and the rest of the set runs on.
TEST(ProcessFault, AHangWithoutOnOverrunIsCountedWhileTheRestRunsOn) {
    Cell cell(process("p", value("args", "--hang-at 5")));
    ASSERT_TRUE(cell.waitUntil([&] { return cell.module("p").value("overruns", uint64_t{0}) > 0; }))
        << cell.module("p").dump();
    EXPECT_TRUE(cell.keepRuns());
    const uint64_t missed = cell.module("p").value("missed", uint64_t{0});
    EXPECT_TRUE(cell.waitUntil([&] { return cell.module("p").value("missed", uint64_t{0}) > missed + 10; }));
    EXPECT_EQ(cell.module("p").value("runs", uint64_t{0}), 5u) << "it finished four periods and hangs in its fifth";
    EXPECT_TRUE(cell.events("process_hang", "p").empty());
    EXPECT_TRUE(cell.events("process_exit", "p").empty());
}

TEST(ProcessFault, AHangWithOnOverrunWarnIsReportedOnce) {
    Cell cell(process("p", value("args", "--hang-at 5"),
                      "<on_overrun>warn</on_overrun><overrun_limit>2000000</overrun_limit>"));
    ASSERT_TRUE(cell.waitUntil([&] { return !cell.events("process_hang", "p").empty(); })) << cell.irpd->out();
    EXPECT_TRUE(cell.keepRuns());
    EXPECT_EQ(cell.events("process_hang", "p").size(), 1u);
    EXPECT_TRUE(cell.events("process_exit", "p").empty());
}

// ---- the device side: the plc-robot cell and a drive simulator of its own ---------------------

namespace {

using testing_support::DriveSim;
using testing_support::eventually;
using testing_support::ModbusClient;

// The plc-robot cell (build/sets/plc-robot) in a scratch folder, without its drive simulator
// module, talking to `port`; `extra` modules are added to its module.xml.
struct PlcCell {
    TempDir dir;
    std::string socket = (dir.path / "irpd.sock").string();
    std::string instance = uniqueInstance();
    std::unique_ptr<Process> irpd;
    std::unique_ptr<Client> client;

    PlcCell(int port, std::string extra) {
        for (std::size_t at; (at = extra.find("@DIR@")) != std::string::npos;) extra.replace(at, 5, dir.path.string());
        const fs::path set = fs::path(BUILD_ROOT) / "sets" / "plc-robot";
        for (const char *f : {"main.so", "Robot.so", "libiodispat.so", "indurop6.urdf", "robot.json", "layout.json"})
            fs::copy_file(set / f, dir.path / f);
        fs::copy_file(kModules / "overrun.so", dir.path / "overrun.so");
        std::string xml = readFile(set / "module.xml");
        xml = std::regex_replace(xml, std::regex("<module>\\s*<name>drivesim</name>[\\s\\S]*?</module>"), "");
        xml.replace(xml.rfind("</root>"), 7, extra + "</root>\n");
        std::ofstream(dir.path / "module.xml") << xml;
        std::string io = readFile(set / "ioconfig.xml");
        io = std::regex_replace(io, std::regex("port=\"15020\""), "port=\"" + std::to_string(port) + "\"");
        std::ofstream(dir.path / "ioconfig.xml") << io;
        std::tie(irpd, client) = startIrpd(dir.path, socket, instance);
    }
    ~PlcCell() {
        client.reset();
        kill(irpd->pid(), SIGKILL);
        irpd->wait(std::chrono::seconds(10));
        // The shared memory the killed irpd leaves behind.
        for (const auto &entry : fs::directory_iterator("/dev/shm"))
            if (entry.path().filename().string().rfind("indurop." + instance + ".", 0) == 0) fs::remove(entry.path());
    }
    void enableDrives() {
        json answer = client->request({{"cmd", "write"}, {"path", "PLC_ROBOT.PLC_IN.Enable"}, {"value", 1}});
        ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    }
};

constexpr int kAxes = 6;
uint16_t statusword(ModbusClient &c, int axis) { return c.input1(8 * axis); }
bool operationEnabled(uint16_t sw) { return (sw & 0x6F) == 0x27; }
bool fault(uint16_t sw) { return (sw & 0x4F) == 0x08; }

// Every axis of the simulator reaches operation enabled (the PLC powers them after enableDrives).
::testing::AssertionResult allOperationEnabled(ModbusClient &probe) {
    for (int axis = 0; axis < kAxes; ++axis)
        if (!eventually([&] { return operationEnabled(statusword(probe, axis)); }, std::chrono::seconds(20)))
            return ::testing::AssertionFailure() << "axis " << axis << " is not operation enabled";
    return ::testing::AssertionSuccess();
}

}  // namespace

TEST(DeviceSide, AStopDrivesTheControlwordsToZeroWhileTheFaultyModuleIsStillStuck) {
    // At SCHED_FIFO, as a drive answers from hardware of its own: libiodispat's safe write gives a
    // device three tries of 20 ms, and a simulator starved by a loaded machine misses all three.
    DriveSim sim({"--quiet", "--rt-priority", "10"});
    ModbusClient probe(sim.port());
    // `stuck` (priority 0: before the I/O) spins 3 s in its 600th run (6 s in), whatever happens.
    PlcCell cell(sim.port(),
                 "<module><name>stuck</name><filename>./overrun.so</filename><moduletype>thread</moduletype>"
                 "<operationtype>periodic</operationtype><period>10000000</period><priority>0</priority>"
                 "<on_overrun>stop</on_overrun><property>" +
                     value("journal", "@DIR@/stuck.log") + value("hang_at", "600") + value("hang_ms", "3000") +
                     "</property></module>\n");
    cell.enableDrives();
    ASSERT_TRUE(eventually([&] { return operationEnabled(statusword(probe, 0)); }, std::chrono::seconds(20)));
    const std::string journal = (cell.dir.path / "stuck.log").string();
    ASSERT_TRUE(eventually([&] { return contains(readFile(journal), "safe_outputs"); }, std::chrono::seconds(20)));
    // The controlwords the simulator holds become 0 (disable voltage) while run 600 still spins:
    // libiodispat's safe write may still be on its way when stuck's own safe_outputs() journals
    // (it writes axis after axis, and a loaded machine spreads them out).
    const auto controlwordsZero = [&] {
        for (int axis = 0; axis < kAxes; ++axis)
            if (probe.holding(4 * axis, 1)[0] != 0) return false;
        return true;
    };
    EXPECT_TRUE(eventually(controlwordsZero, std::chrono::milliseconds(2000)));
    for (int axis = 0; axis < kAxes; ++axis) EXPECT_EQ(probe.holding(4 * axis, 1)[0], 0) << axis;
    EXPECT_FALSE(contains(readFile(journal), "overran")) << readFile(journal);
    EXPECT_TRUE(eventually([&] { return !operationEnabled(statusword(probe, 0)); }));
    json status = cell.client->request({{"cmd", "status"}});
    EXPECT_TRUE(contains(status["result"].value("stopped_by_fault", ""), "stuck")) << status.dump();
    // libiodispat and stuck itself have safe_outputs().  libiodispat tries a late device three
    // times (IoDispatModbus.SafeOutputsAreTriedAgain...); what the simulator holds, checked above,
    // is what counts, whatever the count of modules in the message.
    bool stopped = false;
    const json events = cell.client->request({{"cmd", "events"}});
    for (const json &e : events["result"]["events"])
        stopped |= e["kind"] == "stopped" && contains(e["message"], "driven to safe values");
    EXPECT_TRUE(stopped) << events.dump();
}

TEST(DeviceSide, IrpdKilledLeavesTheDrivesToTheirCommTimeoutWhichQuickStopsThem) {
    // 500 ms: a loaded test machine may stall irpd's start for a fraction of that
    DriveSim sim({"--comm-timeout", "500"});
    ModbusClient probe(sim.port());
    PlcCell cell(sim.port(), "");
    cell.enableDrives();
    ASSERT_TRUE(allOperationEnabled(probe));
    kill(cell.irpd->pid(), SIGKILL);
    ASSERT_EQ(cell.irpd->wait(std::chrono::seconds(10)), -2);
    for (int axis = 0; axis < kAxes; ++axis) {
        EXPECT_TRUE(eventually([&] { return fault(statusword(probe, axis)); })) << axis;
        EXPECT_EQ(probe.input1(8 * axis + 1), 0x8130) << axis;  // error code: comm timeout
        EXPECT_EQ(probe.input32(8 * axis + 5), 0) << axis;      // standing still
    }
    EXPECT_TRUE(contains(sim.out(), "comm timeout: no write for")) << sim.out();
}

namespace {

// The `alarms` answer's source of `module`.
json alarmSource(Client &client, const std::string &module) {
    const json answer = client.request({{"cmd", "alarms"}});
    for (const json &s : answer["result"]["sources"])
        if (s["module"] == module) return s;
    return json();
}

bool active(Client &client, const std::string &module, int id) {
    const json source = alarmSource(client, module);
    return source.is_object() &&
           std::find(source["active"].begin(), source["active"].end(), id) != source["active"].end();
}

}  // namespace

TEST(DeviceSide, TheDrivesStoppingToAnswerRaiseThePlcsAlarm8WithItsTextClearedWhenTheyAreBackThen1000UntilAReset) {
    DriveSim sim({"--quiet"});
    ModbusClient probe(sim.port());
    PlcCell cell(sim.port(), "");
    cell.enableDrives();
    ASSERT_TRUE(allOperationEnabled(probe));
    const json plc = alarmSource(*cell.client, "main");
    ASSERT_TRUE(plc.is_object()) << cell.client->request({{"cmd", "alarms"}}).dump();
    std::string text;
    for (const json &d : plc["declared"])
        if (d["id"] == 8) text = d["text"];
    EXPECT_EQ(text, "Drive communication lost: the drives' I/O device does not answer");
    EXPECT_TRUE(plc["active"].empty()) << plc.dump();

    // The simulator stops answering (stopped, its connections open): comm lost, the robot's
    // ErrorID 8, the PLC stops with it and raises alarm 8; libiodispat raises its comm lost.
    ASSERT_EQ(kill(sim.pid(), SIGSTOP), 0);
    EXPECT_TRUE(eventually([&] { return active(*cell.client, "main", 8); }, std::chrono::seconds(20)))
        << alarmSource(*cell.client, "main").dump();
    EXPECT_TRUE(active(*cell.client, "libiodispat", 100)) << alarmSource(*cell.client, "libiodispat").dump();
    // The record in the ring: from the PLC's source, its value the ErrorID.
    const json status = cell.client->request({{"cmd", "status"}});
    auto mapped = irp::osal::SharedMemory::open(status["result"]["shared_memory"]["alarms"], false);
    ASSERT_TRUE(mapped.ok());
    const auto *header = static_cast<const indurop_alarm_header *>(mapped->data());
    bool recorded = false;
    for (uint64_t seq = 1; seq <= header->head; ++seq)
        if (auto r = testing_support::AlarmRing(header).read(seq); r && r->id == 8)
            recorded = r->source == plc["source"] && r->action == INDUROP_ALARM_RAISE && r->value == 8 && r->flags == 0;
    EXPECT_TRUE(recorded);

    // Back: libiodispat clears its alarm, and the PLC its 8 (its condition is gone); the PLC's error
    // stays latched, so 1000 says the cell waits for a reset, which clears it.
    ASSERT_EQ(kill(sim.pid(), SIGCONT), 0);
    EXPECT_TRUE(eventually([&] { return !active(*cell.client, "libiodispat", 100); }, std::chrono::seconds(20)));
    EXPECT_TRUE(eventually([&] { return !active(*cell.client, "main", 8); }, std::chrono::seconds(20)));
    EXPECT_TRUE(eventually([&] { return active(*cell.client, "main", 1000); }, std::chrono::seconds(20)))
        << alarmSource(*cell.client, "main").dump();
    for (int edge : {1, 0}) {
        json answer = cell.client->request({{"cmd", "write"}, {"path", "PLC_ROBOT.PLC_IN.Reset"}, {"value", edge}});
        ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    EXPECT_TRUE(
        eventually([&] { return alarmSource(*cell.client, "main")["active"].empty(); }, std::chrono::seconds(20)))
        << alarmSource(*cell.client, "main").dump();
    const json after = alarmSource(*cell.client, "main");
    EXPECT_GE(after["recorded"].get<int>(), 4);  // 8 raised and cleared, 1000 raised and cleared
    EXPECT_EQ(after["undeclared"], 0);
}

// ---- modules generated from Structured Text (docs/st-runtime.md) ----------------------------------
// Written here by hand as the generator writes them, on the ST runtime <indurop/st/st.hpp>.

// Whether the libindurop the modules load against has the flag the loop guard polls, which came
// with the fault event's text (i29-st-watch): without them these tests are skipped.
bool libinduropHasRunAbort() {
    void *lib = dlopen((std::string(BUILD_ROOT) + "/rtcore/libindurop.so").c_str(), RTLD_NOW | RTLD_LOCAL);
    const bool has = lib && dlsym(lib, "_ZN3irp17runAbortRequestedEv");
    if (lib) dlclose(lib);
    return has;
}

// A division by zero faults through the runtime: the event names the ST file, line, column, program.
TEST(StFault, ADivisionByZeroIsAFaultEventNamingTheStPlace) {
    if (!libinduropHasRunAbort()) GTEST_SKIP() << "this irpd's fault event does not carry the text (i29-st-watch)";
    Cell cell(thread("Main", (kModules / "st_divide.so").string(), 2'000'000, 2));
    ASSERT_TRUE(cell.waitUntil([&] { return !cell.events("fault", "Main").empty(); }));
    const json fault = cell.events("fault", "Main").at(0);
    EXPECT_TRUE(contains(fault["message"], "run(): main.st:12:9: division by zero (PROGRAM Main)")) << fault.dump();
    EXPECT_EQ(cell.module("Main").value("state", ""), "disabled") << cell.module("Main").dump();
    EXPECT_EQ(cell.module("Main").value("errors", 0), 1);
    EXPECT_TRUE(cell.waitUntil([&] { return cell.runs("Main") == 4u; })) << cell.runs("Main");  // folded within ~1 ms
    EXPECT_TRUE(cell.keepRuns());
}

// An endless WHILE: the overrun watchdog asks the run to end (irp::runAbortRequested()), the loop
// guard throws naming the loop's line, the module is disabled and the rest runs on.
TEST(StFault, AnEndlessLoopIsStoppedAndNamedByItsLine) {
    if (!libinduropHasRunAbort()) GTEST_SKIP() << "this libindurop has no irp::runAbortRequested()";
    Cell cell(thread("Main", (kModules / "st_loop.so").string(), 2'000'000, 2,
                     "<on_overrun>disable</on_overrun><overrun_limit>2000000</overrun_limit>"));
    ASSERT_TRUE(cell.waitUntil([&] { return !cell.events("fault", "Main").empty(); }));
    const json fault = cell.events("fault", "Main").at(0);
    EXPECT_TRUE(contains(fault["message"], "run(): main.st:30:5: the run passed its overrun limit in the loop at "
                                           "line 30: endless loop? (PROGRAM Main)"))
        << fault.dump();
    EXPECT_EQ(cell.module("Main").value("state", ""), "disabled") << cell.module("Main").dump();
    EXPECT_TRUE(cell.keepRuns());
}
