// test_reload.cpp -- hot reload through irpd's control socket: a kept module keeps its instance
// and misses no run, a changed .so is really its new code, failed loads leave the running set
// untouched, periods, priorities and enable/disable are hot reloads too (several modules at once
// as one swap with `change`, or only planned with its dry run), every swap is an event; and the
// `histograms` command's buckets agree with the figures.
#include "support/control_client.hpp"
#include "support/irpd.hpp"
#include "support/subprocess.hpp"

#include <gtest/gtest.h>

#include <signal.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>
#include <thread>

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

std::string module(const std::string &name, const std::string &file, int64_t period_ns, int priority,
                   const std::string &extra = "") {
    return "  <module><name>" + name + "</name><filename>" + file +
           "</filename><moduletype>thread</moduletype><operationtype>periodic</operationtype><period>" +
           std::to_string(period_ns) + "</period><priority>" + std::to_string(priority) + "</priority>" + extra +
           "</module>\n";
}

std::string journalOf(const fs::path &dir, const std::string &name) {
    return "<property><value name=\"journal\">" + (dir / (name + ".log")).string() + "</value></property>";
}

// irpd on a set of counter modules in a scratch folder, with its control socket.
struct Cell {
    TempDir dir;
    std::string socket = (dir.path / "irpd.sock").string();
    std::unique_ptr<Process> irpd;
    std::unique_ptr<Client> client;

    // keep.so (v1, 1 ms) and swap.so (v1, 2 ms)
    Cell() {
        fs::copy_file(kModules / "counter_v1.so", dir.path / "keep.so");
        fs::copy_file(kModules / "counter_v1.so", dir.path / "swap.so");
        write("module.xml", "<root>\n" + module("keep", "keep.so", 1'000'000, 1, journalOf(dir.path, "keep")) +
                                module("swap", "swap.so", 2'000'000, 2, journalOf(dir.path, "swap")) + "</root>\n");
        irpd = std::make_unique<Process>(
            std::vector<std::string>{kIrpd, "--config", (dir.path / "module.xml").string(), "--control-socket", socket,
                                     "--instance", uniqueInstance(), "--module-cache", (dir.path / "cache").string(),
                                     "--stats-json", (dir.path / "stats.json").string()},
            dir.path);
        EXPECT_TRUE(irpd->waitForErr("irpd: running")) << irpd->err();
        client = std::make_unique<Client>(socket, 60);
        EXPECT_FALSE(client->readLine().empty());  // the hello
    }
    ~Cell() {
        client.reset();
        kill(irpd->pid(), SIGTERM);
        irpd->wait(std::chrono::seconds(10));
    }
    void write(const std::string &name, const std::string &text) { std::ofstream(dir.path / name) << text; }
    json ask(const json &request) { return client->request(request); }
    json result(const json &request) {
        json answer = ask(request);
        EXPECT_TRUE(answer.value("ok", false)) << request.dump() << " -> " << answer.dump();
        return answer.value("result", json());
    }
    json moduleNamed(const std::string &name) {
        for (const json &m : result({{"cmd", "modules"}}))
            if (m["name"] == name) return m;
        return json();
    }
    std::string log(const std::string &name) { return readFile(dir.path / (name + ".log")); }
};

uint64_t count(const json &m, const char *what) { return m.value(what, uint64_t{0}); }

// How many processes have `parent` as their parent.
std::size_t children(pid_t parent) {
    std::size_t n = 0;
    for (const auto &entry : fs::directory_iterator("/proc")) {
        const std::string stat = readFile(entry.path() / "stat");
        const auto close = stat.rfind(')');
        if (close == std::string::npos) continue;
        std::istringstream rest(stat.substr(close + 2));
        std::string state;
        pid_t ppid = 0;
        rest >> state >> ppid;
        n += ppid == parent;
    }
    return n;
}

}  // namespace

TEST(HotReload, AKeptModuleKeepsItsInstanceAndAChangedOneIsItsNewCode) {
    Cell cell;
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    // swap.so is rebuilt (v2) at the same path; keep.so is untouched.
    fs::copy_file(kModules / "counter_v2.so", cell.dir.path / "swap.so", fs::copy_options::overwrite_existing);
    json report =
        cell.result({{"cmd", "load"}, {"config", (cell.dir.path / "module.xml").string()}, {"set_id", "abc"}});
    EXPECT_EQ(report["kept"], json({"keep"}));
    EXPECT_EQ(report["started"], json({"swap"}));
    EXPECT_EQ(report["stopped"], json({"swap"}));
    EXPECT_EQ(report["generation"], 2);
    EXPECT_EQ(report["set_id"], "abc");
    EXPECT_GT(report["swap_cycle"].get<uint64_t>(), 0u);
    EXPECT_EQ(report["swap_cycle"].get<uint64_t>() % 2, 0u) << "a swap happens at a macro-period boundary (2 slots)";
    EXPECT_TRUE(report.contains("missed_periods"));
    // The old swap module was stopped after the new one started: the new code runs.
    EXPECT_TRUE(std::regex_search(cell.log("swap"), std::regex("^start v1\nstart v2\nstop v1 runs=[0-9]+\n$")))
        << cell.log("swap");
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    json status = cell.result({{"cmd", "status"}});
    EXPECT_EQ(status["generation"], 2);
    EXPECT_EQ(status["set_id"], "abc");
    EXPECT_GT(count(cell.moduleNamed("swap"), "runs"), 0u);

    // At the end: keep was started once and counted one run per period, across the swap.
    json keep = cell.moduleNamed("keep");
    const uint64_t runs_seen = count(keep, "runs");
    kill(cell.irpd->pid(), SIGTERM);
    ASSERT_EQ(cell.irpd->wait(std::chrono::seconds(10)), 0) << cell.irpd->err();
    std::smatch m;
    const std::string keep_log = cell.log("keep");
    ASSERT_TRUE(std::regex_match(keep_log, m, std::regex("start v1\nstop v1 runs=([0-9]+)\n"))) << keep_log;
    EXPECT_GE(std::stoull(m[1]), runs_seen);
    EXPECT_TRUE(std::regex_search(cell.log("swap"), std::regex("stop v2 runs=[0-9]+\n$"))) << cell.log("swap");
}

TEST(HotReload, AKeptModuleRunsInEveryPeriodAcrossSwaps) {
    Cell cell;
    for (int i = 0; i < 5; ++i) {
        fs::copy_file(kModules / (i % 2 ? "counter_v1.so" : "counter_v2.so"), cell.dir.path / "swap.so",
                      fs::copy_options::overwrite_existing);
        json report = cell.result({{"cmd", "load"}, {"config", (cell.dir.path / "module.xml").string()}});
        EXPECT_EQ(report["kept"], json({"keep"}));
    }
    kill(cell.irpd->pid(), SIGTERM);
    ASSERT_EQ(cell.irpd->wait(std::chrono::seconds(10)), 0) << cell.irpd->err();
    // One instance from start to stop, whose own count is every run irpd made of it, and
    // (runs + skipped) = every 1 ms period the dispatcher went through: no period lost to a swap.
    std::smatch m;
    const std::string keep_log = cell.log("keep");
    ASSERT_TRUE(std::regex_match(keep_log, m, std::regex("start v1\nstop v1 runs=([0-9]+)\n"))) << keep_log;
    const json stats = json::parse(readFile(cell.dir.path / "stats.json"));
    EXPECT_EQ(stats["generation"], 6);
    const json &keep = stats["modules"][0];
    ASSERT_EQ(keep["name"], "keep");
    EXPECT_EQ(std::stoull(m[1]), keep["runs"].get<uint64_t>());
    const json &dispatcher = stats["dispatcher"];
    EXPECT_EQ(keep["runs"].get<uint64_t>() + keep["skipped"].get<uint64_t>(),
              dispatcher["runs"].get<uint64_t>() + dispatcher["skipped"].get<uint64_t>());
    EXPECT_GT(keep["runs"].get<uint64_t>(), 0u);
}

TEST(HotReload, AFailedLoadLeavesTheRunningSetUntouched) {
    Cell cell;
    const json before = cell.result({{"cmd", "status"}});
    struct Case {
        std::string name, xml, expected;
    };
    fs::copy_file(kModules / "no_run_plain.so", cell.dir.path / "norun.so");
    fs::copy_file(kModules / "init_throws.so", cell.dir.path / "throws.so");
    fs::copy_file(kModules / "not_elf.so", cell.dir.path / "notelf.so");
    const std::string keep = module("keep", "keep.so", 1'000'000, 1, journalOf(cell.dir.path, "keep"));
    const std::vector<Case> cases = {
        {"syntax", "<root><module>", "malformed XML"},
        {"missing file", "<root>" + keep + module("x", "nothere.so", 1'000'000, 2) + "</root>", "does not exist"},
        {"no run", "<root>" + keep + module("x", "norun.so", 1'000'000, 2) + "</root>", "run"},
        {"initialize throws", "<root>" + keep + module("x", "throws.so", 1'000'000, 2) + "</root>", "initialize"},
        {"not ELF", "<root>" + keep + module("x", "notelf.so", 1'000'000, 2) + "</root>", "cannot load"},
        {"GCD below the minimum", "<root>" + keep + module("x", "swap.so", 10'000, 2) + "</root>", "minimum"},
        {"over 100 %",
         "<root>" + keep + module("x", "swap.so", 1'000'000, 2, "<budget>600000</budget>") +
             module("y", "keep.so", 1'000'000, 3, "<budget>600000</budget>") + "</root>",
         "busy"},
    };
    for (const Case &c : cases) {
        cell.write("bad.xml", c.xml);
        json answer = cell.ask({{"cmd", "load"}, {"config", (cell.dir.path / "bad.xml").string()}});
        EXPECT_FALSE(answer.value("ok", true)) << c.name;
        const std::string message = answer["error"].value("message", "");
        EXPECT_NE(message.find(c.expected), std::string::npos) << c.name << ": " << message;
    }
    const json after = cell.result({{"cmd", "status"}});
    EXPECT_EQ(after["generation"], before["generation"]);
    EXPECT_EQ(after["set"], before["set"]);
    EXPECT_GT(after["cycles"].get<uint64_t>(), before["cycles"].get<uint64_t>());
    json names = json::array();
    for (const json &m : cell.result({{"cmd", "modules"}})) names.push_back(m["name"]);
    EXPECT_EQ(names, json({"keep", "swap"}));
    // What was loaded for a failed attempt is gone again: only keep and swap's states remain.
    EXPECT_EQ(cell.log("keep"), "start v1\n");
    // Each failure is an event.
    json events = cell.result({{"cmd", "events"}});
    std::size_t failed = 0;
    for (const json &e : events["events"]) failed += e["kind"] == "swap_failed";
    EXPECT_EQ(failed, cases.size());
}

// A swap that fails halfway: new modules before the failing one were loaded, initialized and
// started; they are stopped and unloaded again, the ones after it never start, and the running
// set goes on untouched (the same generation, keep neither restarted nor stopped).
TEST(HotReload, ASwapThatFailsHalfwayStopsWhatItStartedAndLeavesTheRunningSetUntouched) {
    Cell cell;
    fs::copy_file(kModules / "counter_v2.so", cell.dir.path / "a.so");
    fs::copy_file(kModules / "counter_v2.so", cell.dir.path / "c.so");
    fs::copy_file(kModules / "init_throws.so", cell.dir.path / "throws.so");
    fs::copy_file(kModules / "not_elf.so", cell.dir.path / "notelf.so");
    fs::copy_file(kModules / "start_throws.so", cell.dir.path / "startthrows.so");
    const std::string exe = std::string(FIXTURE_PROCESSES) + "/proc_periodic.exe";
    const std::string keep = module("keep", "keep.so", 1'000'000, 1, journalOf(cell.dir.path, "keep"));
    auto fresh = [&](const std::string &name) {
        return module(name, name + ".so", 2'000'000, 2, journalOf(cell.dir.path, name));
    };
    // New thread modules are all loaded, then all initialized, then started in file order;
    // processes start after them.  a_log, c_log: what a and c (before and after the failing x)
    // must have journaled: every start() stopped again.
    const std::string started = "start v2\nstop v2 runs=0\n";
    struct Case {
        std::string name, failing, expected, a_log, c_log;
    };
    const std::vector<Case> cases = {
        {"not loadable", module("x", "notelf.so", 2'000'000, 3), "cannot load", "", ""},
        {"initialize throws", module("x", "throws.so", 2'000'000, 3), "initialize", "", ""},
        {"start throws", module("x", "startthrows.so", 2'000'000, 3), "drive not ready", started, ""},
        {"a process that exits before it is ready",
         "  <module><name>x</name><filename>" + exe +
             "</filename><moduletype>process</moduletype><operationtype>periodic</operationtype><period>2000000</"
             "period>"
             "<priority>3</priority><property><value name=\"args\">--exit-now 3</value><value "
             "name=\"restart\">never</value>"
             "</property></module>\n",
         "x", started, started},
    };
    for (const Case &c : cases) {
        fs::remove(cell.dir.path / "a.log");
        fs::remove(cell.dir.path / "c.log");
        const json before = cell.result({{"cmd", "status"}});
        const uint64_t keep_runs = count(cell.moduleNamed("keep"), "runs");
        cell.write("half.xml", "<root>\n" + keep + fresh("a") + c.failing + fresh("c") + "</root>\n");
        json answer = cell.ask({{"cmd", "load"}, {"config", (cell.dir.path / "half.xml").string()}});
        ASSERT_FALSE(answer.value("ok", true)) << c.name;
        EXPECT_NE(answer["error"].value("message", "").find(c.expected), std::string::npos)
            << c.name << ": " << answer.dump();
        // What the attempt started it stopped again; what came after the failure never started.
        EXPECT_EQ(cell.log("a"), c.a_log) << c.name;
        EXPECT_EQ(cell.log("c"), c.c_log) << c.name;
        // The running set: the same generation and modules, keep still running, never restarted.
        const json after = cell.result({{"cmd", "status"}});
        EXPECT_EQ(after["generation"], before["generation"]) << c.name;
        json names = json::array();
        for (const json &m : cell.result({{"cmd", "modules"}})) names.push_back(m["name"]);
        EXPECT_EQ(names, json({"keep", "swap"})) << c.name;
        const uint64_t later = keep_runs;
        EXPECT_TRUE([&] {
            for (int i = 0; i < 200; ++i) {
                if (count(cell.moduleNamed("keep"), "runs") > later + 10) return true;
                std::this_thread::sleep_for(std::chrono::milliseconds(10));
            }
            return false;
        }()) << c.name;
        EXPECT_EQ(cell.log("keep"), "start v1\n") << c.name;
    }
    std::size_t failed = 0;
    const json events = cell.result({{"cmd", "events"}});
    for (const json &e : events["events"]) failed += e["kind"] == "swap_failed";
    EXPECT_EQ(failed, cases.size()) << events.dump();
}

TEST(HotReload, PeriodPriorityAndEnableAreHotReloadsOfTheRunningSet) {
    Cell cell;
    json report = cell.result({{"cmd", "set_period"}, {"module", "swap"}, {"period_ns", 4'000'000}});
    EXPECT_EQ(report["kept"], json({"keep", "swap"}));
    EXPECT_EQ(report["started"], json::array());
    EXPECT_EQ(report["macro_period_ns"], 4'000'000);
    EXPECT_EQ(cell.moduleNamed("swap")["period_ns"], 4'000'000);
    json schedule = cell.result({{"cmd", "schedule"}});
    EXPECT_EQ(schedule["macro_period_ns"], 4'000'000);

    report = cell.result({{"cmd", "set_priority"}, {"module", "swap"}, {"priority", 0}});
    EXPECT_EQ(cell.moduleNamed("swap")["priority"], 0);
    schedule = cell.result({{"cmd", "schedule"}});
    EXPECT_EQ(schedule["slots"][0]["modules"], json({"swap", "keep"}));

    cell.result({{"cmd", "disable"}, {"module", "swap"}});
    json swap = cell.moduleNamed("swap");
    EXPECT_EQ(swap["enabled"], false);
    EXPECT_EQ(swap["state"], "disabled");
    const uint64_t runs = count(swap, "runs");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    EXPECT_EQ(count(cell.moduleNamed("swap"), "runs"), runs);
    cell.result({{"cmd", "enable"}, {"module", "swap"}});
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    EXPECT_GT(count(cell.moduleNamed("swap"), "runs"), runs);
    EXPECT_EQ(cell.log("swap"), "start v1\n");  // one instance all along

    // Refusals name what to fix; nothing changes.
    for (const json &bad : {json{{"cmd", "set_period"}, {"module", "nope"}, {"period_ns", 1'000'000}},
                            json{{"cmd", "set_period"}, {"module", "swap"}, {"period_ns", -5}},
                            json{{"cmd", "set_period"}, {"module", "swap"}, {"period_ns", 1000}},
                            json{{"cmd", "set_period"}, {"module", "swap"}},
                            json{{"cmd", "set_priority"}, {"module", "swap"}, {"priority", "high"}}}) {
        json answer = cell.ask(bad);
        EXPECT_FALSE(answer.value("ok", true)) << bad.dump();
    }
    EXPECT_EQ(cell.moduleNamed("swap")["period_ns"], 4'000'000);
    json events = cell.result({{"cmd", "events"}, {"since", 0}});
    std::size_t swaps = 0;
    for (const json &e : events["events"]) swaps += e["kind"] == "swap";
    EXPECT_EQ(swaps, 4u);
}

TEST(HotReload, CheckValidatesWithoutLoading) {
    Cell cell;
    json good = cell.result({{"cmd", "check"}, {"config", (cell.dir.path / "module.xml").string()}});
    EXPECT_EQ(good["valid"], true);
    EXPECT_EQ(good["schedule"]["basic_period_ns"], 1'000'000);
    cell.write("bad.xml",
               "<root>" + module("x", "swap.so", 10'000, 2) + module("y", "gone.so", 1'000'000, 1) + "</root>");
    json bad = cell.result({{"cmd", "check"}, {"config", (cell.dir.path / "bad.xml").string()}});
    EXPECT_EQ(bad["valid"], false);
    EXPECT_EQ(bad["errors"].size(), 2u) << bad.dump();
    EXPECT_EQ(cell.log("swap"), "start v1\n");
}

// A bad process property is refused when module.xml is read: `check` (the agent's validation,
// `irpctl validate`), `load` and `restart` all say so with file:line, the module, the property and
// the accepted values, before anything starts.
TEST(HotReload, CheckRefusesABadProcessPropertyWithFileLine) {
    Cell cell;
    const std::string exe = std::string(FIXTURE_PROCESSES) + "/proc_periodic.exe";
    cell.write("bad.xml", "<root>\n" + module("keep", "keep.so", 1'000'000, 1) + "  <module><name>p</name><filename>" +
                              exe +
                              "</filename><moduletype>process</moduletype><operationtype>periodic</operationtype>\n"
                              "    <period>2000000</period><priority>3</priority>\n"
                              "    <property><value name=\"restart\">sometimes</value></property></module>\n</root>\n");
    const std::string xml = (cell.dir.path / "bad.xml").string();
    const std::string expected =
        xml + ":5: module 'p': property restart = 'sometimes': expected never, always or on-failure";
    json checked = cell.result({{"cmd", "check"}, {"config", xml}});
    EXPECT_EQ(checked["valid"], false);
    EXPECT_EQ(checked["errors"], json({expected})) << checked.dump();
    for (const char *cmd : {"load", "restart"}) {
        json refused = cell.ask({{"cmd", cmd}, {"config", xml}});
        EXPECT_FALSE(refused.value("ok", true)) << cmd << ": " << refused.dump();
        EXPECT_EQ(refused["error"].value("message", ""), expected) << cmd;
    }
    EXPECT_EQ(cell.irpd->out().find("[p] "), std::string::npos) << "nothing of it started";
    EXPECT_EQ(cell.result({{"cmd", "status"}})["generation"], 1);
}

TEST(HotReload, ProcessModulesAreKeptReplacedOrRefusedLikeThreads) {
    Cell cell;
    const std::string exe = std::string(FIXTURE_PROCESSES) + "/proc_periodic.exe";
    auto process = [&](const std::string &args) {
        return "  <module><name>p</name><filename>" + exe +
               "</filename><moduletype>process</moduletype><operationtype>periodic</operationtype>"
               "<period>2000000</period><priority>3</priority><property><value name=\"args\">" +
               args + "</value></property></module>\n";
    };
    const std::string threads = module("keep", "keep.so", 1'000'000, 1, journalOf(cell.dir.path, "keep"));
    auto load = [&](const std::string &body) {
        cell.write("p.xml", "<root>\n" + threads + body + "</root>\n");
        return cell.ask({{"cmd", "load"}, {"config", (cell.dir.path / "p.xml").string()}});
    };
    auto starts = [&] {
        std::size_t n = 0;
        for (std::size_t at = 0; (at = cell.irpd->out().find("[p] start pid=", at)) != std::string::npos; ++at) ++n;
        return n;
    };
    json a = load(process("--env A"));
    ASSERT_TRUE(a.value("ok", false)) << a.dump();
    EXPECT_EQ(a["result"]["started"], json({"p"}));
    EXPECT_EQ(a["result"]["stopped"], json({"swap"}));
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    EXPECT_GT(count(cell.moduleNamed("p"), "runs"), 0u);

    json same = load(process("--env A"));  // the same process: kept, not restarted
    ASSERT_TRUE(same.value("ok", false)) << same.dump();
    EXPECT_EQ(same["result"]["kept"], json({"keep", "p"}));
    EXPECT_EQ(starts(), 1u) << cell.irpd->out();

    json refused = load(process("--no-init"));  // a new process that never gets ready
    EXPECT_FALSE(refused.value("ok", true));
    EXPECT_NE(refused["error"].value("message", "").find("not ready"), std::string::npos) << refused.dump();
    const uint64_t runs = count(cell.moduleNamed("p"), "runs");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    EXPECT_GT(count(cell.moduleNamed("p"), "runs"), runs) << "the running process goes on";

    json changed = load(process("--env B"));  // other properties: a new process replaces it
    ASSERT_TRUE(changed.value("ok", false)) << changed.dump();
    EXPECT_EQ(changed["result"]["started"], json({"p"}));
    EXPECT_EQ(changed["result"]["stopped"], json({"p"}));
    EXPECT_EQ(children(cell.irpd->pid()), 1u) << "the old process was stopped";
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    json p = cell.moduleNamed("p");
    EXPECT_EQ(p["state"], "running");
    EXPECT_GT(count(p, "runs"), 0u);
    EXPECT_EQ(cell.log("keep"), "start v1\n");
}

namespace {

// The value at quantile q of a histogram as `histograms` lists it, computed as stats/summary.cpp
// does: the middle of the bucket holding rank ceil(q * count), clamped to [min, max].
double quantileOf(const json &h, double q) {
    const uint64_t count = h["count"].get<uint64_t>();
    const uint64_t rank =
        std::clamp<uint64_t>(static_cast<uint64_t>(std::ceil(q * static_cast<double>(count))), 1, count);
    uint64_t seen = 0;
    for (const json &b : h["buckets"]) {
        seen += b[2].get<uint64_t>();
        if (seen >= rank) {
            const double mid = b[0].get<double>() + (b[1].get<double>() - 1) / 2;
            return std::clamp(mid, h["min"].get<double>(), h["max"].get<double>());
        }
    }
    return h["max"].get<double>();
}

bool hasWarning(const json &answer, const std::string &part) {
    for (const json &w : answer["warnings"])
        if (w.get<std::string>().find(part) != std::string::npos) return true;
    return false;
}

std::size_t eventsOfKind(Cell &cell, const std::string &kind) {
    const json events = cell.result({{"cmd", "events"}, {"since", 0}});
    std::size_t n = 0;
    for (const json &e : events["events"]) n += e["kind"] == kind;
    return n;
}

}  // namespace

TEST(HotReload, HistogramsListTheNonEmptyBucketsThatAddUpToTheCounts) {
    Cell cell;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    const json all = cell.result({{"cmd", "histograms"}});
    EXPECT_GT(all["cycles"].get<uint64_t>(), 0u);
    EXPECT_GT(all["time_ns"].get<int64_t>(), 0);
    json names = json::array();
    for (const json &r : all["records"]) names.push_back(r["name"]);
    EXPECT_EQ(names, json({"dispatcher", "keep", "swap"}));
    for (const json &r : all["records"])
        for (const char *which : {"jitter_ns", "latency_ns", "exec_ns"}) {
            const json &h = r[which];
            uint64_t sum = 0;
            int64_t end = std::numeric_limits<int64_t>::min();
            for (const json &b : h["buckets"]) {
                ASSERT_EQ(b.size(), 3u);
                EXPECT_GE(b[0].get<int64_t>(), end) << r["name"] << " " << which << ": buckets ascend, never overlap";
                EXPECT_GT(b[1].get<int64_t>(), 0);
                EXPECT_GT(b[2].get<uint64_t>(), 0u) << "only non-empty buckets are listed";
                end = b[0].get<int64_t>() + b[1].get<int64_t>();
                sum += b[2].get<uint64_t>();
            }
            EXPECT_EQ(sum, h["count"].get<uint64_t>()) << r["name"] << " " << which;
            EXPECT_GT(sum, 0u) << r["name"] << " " << which;
            EXPECT_GE(h["min"].get<int64_t>(), h["buckets"].front()[0].get<int64_t>());
            EXPECT_LT(h["max"].get<int64_t>(), end);
            if (std::string(which) != "jitter_ns") {
                EXPECT_GE(h["buckets"].front()[0].get<int64_t>(), 0);
            }
        }

    // A disabled module's figures stand still: its histograms and its percentiles agree exactly.
    cell.result({{"cmd", "disable"}, {"module", "swap"}});
    const json one = cell.result({{"cmd", "histograms"}, {"name", "swap"}});
    ASSERT_EQ(one["records"].size(), 1u);
    const json &h = one["records"][0];
    const json figures = cell.moduleNamed("swap");
    EXPECT_EQ(h["runs"], figures["runs"]);
    for (const char *which : {"jitter_ns", "latency_ns", "exec_ns"}) {
        EXPECT_EQ(h[which]["count"], figures[which]["count"]) << which;
        EXPECT_EQ(h[which]["min"].get<double>(), figures[which]["min"].get<double>()) << which;
        EXPECT_EQ(h[which]["max"].get<double>(), figures[which]["max"].get<double>()) << which;
        if (std::string(which) != "jitter_ns") {  // the signed one clamps each half to its own bounds
            EXPECT_EQ(quantileOf(h[which], 0.50), figures[which]["p50"].get<double>()) << which;
            EXPECT_EQ(quantileOf(h[which], 0.99), figures[which]["p99"].get<double>()) << which;
        }
    }
    json unknown = cell.ask({{"cmd", "histograms"}, {"name", "nope"}});
    EXPECT_FALSE(unknown.value("ok", true));
    EXPECT_EQ(unknown["error"]["code"], "not_found");
    EXPECT_NE(unknown["error"]["message"].get<std::string>().find("'nope'"), std::string::npos) << unknown.dump();
}

TEST(HotReload, StatusSaysTheMinimumBasicPeriod) {
    Cell cell;
    EXPECT_EQ(cell.result({{"cmd", "status"}})["min_basic_period_ns"], 50'000);
}

TEST(HotReload, ADryRunChangeShowsTheNewTableAndChangesNothing) {
    Cell cell;
    const json status = cell.result({{"cmd", "status"}});
    const json schedule = cell.result({{"cmd", "schedule"}});
    const json changes = json::array(
        {{{"module", "keep"}, {"period_ns", 2'000'000}}, {{"module", "swap"}, {"priority", 0}, {"enabled", true}}});
    const json dry = cell.result({{"cmd", "change"}, {"changes", changes}, {"dry_run", true}});
    EXPECT_EQ(dry["dry_run"], true);
    EXPECT_TRUE(dry["report"].is_null());
    EXPECT_EQ(dry["before"]["slots"], schedule["slots"]);
    EXPECT_EQ(dry["schedule"]["basic_period_ns"], 2'000'000);
    EXPECT_EQ(dry["schedule"]["slots"], json::array({{{"index", 0}, {"offset_ns", 0}, {"modules", {"swap", "keep"}}}}));
    EXPECT_TRUE(hasWarning(dry, "basic period")) << dry.dump();
    ASSERT_TRUE(dry["utilization"].contains("main"));
    EXPECT_GE(dry["utilization"]["main"].get<double>(), 0.0);
    EXPECT_LT(dry["utilization"]["main"].get<double>(), 1.0);

    // Nothing changed: the same generation and table, keep still counts at 1 ms, no event.
    const uint64_t runs = count(cell.moduleNamed("keep"), "runs");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const json keep = cell.moduleNamed("keep");
    EXPECT_GT(count(keep, "runs"), runs);
    EXPECT_EQ(keep["period_ns"], 1'000'000);
    EXPECT_EQ(cell.result({{"cmd", "status"}})["generation"], status["generation"]);
    EXPECT_EQ(cell.result({{"cmd", "schedule"}}), schedule);
    EXPECT_EQ(eventsOfKind(cell, "swap"), 0u);
    EXPECT_EQ(cell.log("keep"), "start v1\n");
    EXPECT_EQ(cell.log("swap"), "start v1\n");
}

TEST(HotReload, ABatchChangeIsOneSwapOfEveryModuleItNames) {
    Cell cell;
    const json changes =
        json::array({{{"module", "keep"}, {"period_ns", 2'000'000}}, {{"module", "swap"}, {"priority", 0}}});
    const json answer = cell.result({{"cmd", "change"}, {"changes", changes}});
    EXPECT_EQ(answer["dry_run"], false);
    EXPECT_EQ(answer["report"]["generation"], 2);
    EXPECT_EQ(answer["report"]["kept"], json({"keep", "swap"}));
    EXPECT_EQ(answer["report"]["started"], json::array());
    EXPECT_EQ(answer["before"]["basic_period_ns"], 1'000'000);
    EXPECT_EQ(answer["schedule"], cell.result({{"cmd", "schedule"}}));
    EXPECT_EQ(cell.result({{"cmd", "status"}})["generation"], 2);
    EXPECT_EQ(cell.moduleNamed("keep")["period_ns"], 2'000'000);
    EXPECT_EQ(cell.moduleNamed("swap")["priority"], 0);
    EXPECT_EQ(cell.result({{"cmd", "schedule"}})["slots"][0]["modules"], json({"swap", "keep"}));
    EXPECT_EQ(eventsOfKind(cell, "swap"), 1u);

    // Disabling one and changing the other's period is one swap too.
    const json more = cell.result(
        {{"cmd", "change"},
         {"changes", {{{"module", "swap"}, {"enabled", false}}, {{"module", "keep"}, {"period_ns", 1'000'000}}}}});
    EXPECT_EQ(more["report"]["generation"], 3);
    const json swap = cell.moduleNamed("swap");
    EXPECT_EQ(swap["enabled"], false);
    bool listed = false;
    for (const json &m : more["schedule"]["modules"])
        if (m["name"] == "swap") listed = m["enabled"] == false;
    EXPECT_TRUE(listed) << more["schedule"].dump();
    EXPECT_EQ(cell.moduleNamed("keep")["period_ns"], 1'000'000);
    EXPECT_EQ(cell.log("keep"), "start v1\n");  // one instance all along
    EXPECT_EQ(cell.log("swap"), "start v1\n");
}

TEST(HotReload, ChangeRefusalsNameWhatToFixAndLeaveTheSetAsItWas) {
    Cell cell;
    // keep 60 % and swap 30 % busy by their budgets: 90 %, a warning; swap at 1 ms would be 120 %.
    cell.write(
        "budget.xml",
        "<root>\n" +
            module("keep", "keep.so", 1'000'000, 1, journalOf(cell.dir.path, "keep") + "<budget>600000</budget>") +
            module("swap", "swap.so", 2'000'000, 2, journalOf(cell.dir.path, "swap") + "<budget>600000</budget>") +
            "</root>\n");
    const json loaded = cell.result({{"cmd", "load"}, {"config", (cell.dir.path / "budget.xml").string()}});
    ASSERT_EQ(loaded["kept"], json({"keep", "swap"}));
    const json before = cell.result({{"cmd", "status"}});

    const json same_priority =
        cell.result({{"cmd", "change"}, {"changes", {{{"module", "swap"}, {"priority", 1}}}}, {"dry_run", true}});
    EXPECT_TRUE(hasWarning(same_priority, "both have priority 1")) << same_priority.dump();
    EXPECT_TRUE(hasWarning(same_priority, "above 80 %")) << same_priority.dump();
    EXPECT_GE(same_priority["utilization"]["main"].get<double>(), 0.899);

    struct Case {
        std::string name;
        json request;
        std::string code, expected;
    };
    const std::vector<Case> cases = {
        {"unknown module", {{"changes", {{{"module", "nope"}, {"priority", 1}}}}}, "not_found", "no module 'nope'"},
        {"over 100 %", {{"changes", {{{"module", "swap"}, {"period_ns", 1'000'000}}}}}, "refused", "% busy"},
        {"period below the budget",
         {{"changes", {{{"module", "keep"}, {"period_ns", 500'000}}}}},
         "refused",
         "<budget>"},
        {"twice",
         {{"changes", {{{"module", "keep"}, {"priority", 1}}, {{"module", "keep"}, {"period_ns", 2'000'000}}}}},
         "refused",
         "changed twice"},
        {"nothing to change", {{"changes", {{{"module", "keep"}}}}}, "refused", "changes nothing"},
        {"empty", {{"changes", json::array()}}, "refused", "'changes'"},
        {"not a list", {{"changes", "keep"}}, "refused", "'changes'"},
        {"unknown member", {{"changes", {{{"module", "keep"}, {"period", 5}}}}}, "refused", "unknown member 'period'"},
        {"period not an integer", {{"changes", {{{"module", "keep"}, {"period_ns", "1ms"}}}}}, "refused", "period_ns"},
        {"negative period", {{"changes", {{{"module", "keep"}, {"period_ns", -1}}}}}, "refused", "positive"},
        {"enabled not a boolean", {{"changes", {{{"module", "keep"}, {"enabled", 1}}}}}, "refused", "'enabled'"},
        {"dry_run not a boolean",
         {{"changes", {{{"module", "keep"}, {"priority", 1}}}}, {"dry_run", "yes"}},
         "refused",
         "'dry_run'"},
    };
    for (const bool dry_run : {true, false})
        for (const Case &c : cases) {
            json request = c.request;
            request["cmd"] = "change";
            if (!request.contains("dry_run")) request["dry_run"] = dry_run;
            const json answer = cell.ask(request);
            EXPECT_FALSE(answer.value("ok", true)) << c.name;
            EXPECT_EQ(answer["error"]["code"], c.code) << c.name << ": " << answer.dump();
            EXPECT_NE(answer["error"].value("message", "").find(c.expected), std::string::npos)
                << c.name << ": " << answer.dump();
        }
    const json after = cell.result({{"cmd", "status"}});
    EXPECT_EQ(after["generation"], before["generation"]);
    EXPECT_EQ(cell.moduleNamed("keep")["period_ns"], 1'000'000);
    EXPECT_EQ(cell.moduleNamed("swap")["period_ns"], 2'000'000);
    EXPECT_EQ(cell.log("keep"), "start v1\n");
}

TEST(HotReload, AChangeBelowTheMinimumBasicPeriodIsRefused) {
    Cell cell;
    for (const bool dry_run : {true, false}) {
        const json answer = cell.ask(
            {{"cmd", "change"}, {"changes", {{{"module", "keep"}, {"period_ns", 10'000}}}}, {"dry_run", dry_run}});
        EXPECT_FALSE(answer.value("ok", true));
        EXPECT_NE(answer["error"].value("message", "").find("below the minimum basic period of 50000 ns"),
                  std::string::npos)
            << answer.dump();
    }
    EXPECT_EQ(cell.result({{"cmd", "status"}})["generation"], 1);
    EXPECT_EQ(eventsOfKind(cell, "swap_failed"), 1u) << "a refused dry run is no failed swap";
}
