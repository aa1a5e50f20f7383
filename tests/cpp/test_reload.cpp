// test_reload.cpp -- hot reload through irpd's control socket: a kept module keeps its instance
// and misses no run, a changed .so is really its new code, failed loads leave the running set
// untouched, periods, priorities and enable/disable are hot reloads too, and every swap is an
// event.
#include "support/control_client.hpp"
#include "support/irpd.hpp"
#include "support/subprocess.hpp"

#include <gtest/gtest.h>

#include <signal.h>

#include <filesystem>
#include <fstream>
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

} // namespace

TEST(HotReload, AKeptModuleKeepsItsInstanceAndAChangedOneIsItsNewCode) {
    Cell cell;
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    // swap.so is rebuilt (v2) at the same path; keep.so is untouched.
    fs::copy_file(kModules / "counter_v2.so", cell.dir.path / "swap.so", fs::copy_options::overwrite_existing);
    json report = cell.result({{"cmd", "load"}, {"config", (cell.dir.path / "module.xml").string()}, {"set_id", "abc"}});
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
    cell.write("bad.xml", "<root>" + module("x", "swap.so", 10'000, 2) + module("y", "gone.so", 1'000'000, 1) + "</root>");
    json bad = cell.result({{"cmd", "check"}, {"config", (cell.dir.path / "bad.xml").string()}});
    EXPECT_EQ(bad["valid"], false);
    EXPECT_EQ(bad["errors"].size(), 2u) << bad.dump();
    EXPECT_EQ(cell.log("swap"), "start v1\n");
}

TEST(HotReload, ProcessModulesAreKeptReplacedOrRefusedLikeThreads) {
    Cell cell;
    const std::string exe = std::string(FIXTURE_PROCESSES) + "/proc_periodic.exe";
    auto process = [&](const std::string &args) {
        return "  <module><name>p</name><filename>" + exe +
               "</filename><moduletype>process</moduletype><operationtype>periodic</operationtype>"
               "<period>2000000</period><priority>3</priority><property><value name=\"args\">" + args +
               "</value></property></module>\n";
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
