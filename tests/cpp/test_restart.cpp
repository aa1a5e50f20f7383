// test_restart.cpp -- the managed restart through irpd's control socket (docs/hot-reload.md,
// "Managed restart"): irpd stops cleanly and executes itself again, same pid, on a set it could
// not take online, says the downtime it measured; a set that does not start brings the old set
// back; a set refused for a plain reason is refused at once and nothing stops.
#include "support/control_client.hpp"
#include "support/irpd.hpp"
#include "support/subprocess.hpp"

#include <gtest/gtest.h>

#include <signal.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
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

std::string module(const std::string &name, const std::string &file, int64_t period_ns, const std::string &extra = "") {
    return "  <module><name>" + name + "</name><filename>" + file +
           "</filename><moduletype>thread</moduletype><operationtype>periodic</operationtype><period>" +
           std::to_string(period_ns) + "</period><priority>1</priority>" + extra + "</module>\n";
}

// The shared memory an irpd killed on purpose leaves behind.
void removeShm(const std::string &instance) {
    for (const auto &entry : fs::directory_iterator("/dev/shm"))
        if (entry.path().filename().string().rfind("indurop." + instance + ".", 0) == 0) fs::remove(entry.path());
}

// A set with shared variables: irpd started on a set without any has no segment to put them in,
// so only a restart can run it.
std::string variables() {
    return "  <layout>" + (fs::path(ONLINE_DIR) / "oc_v1" / "layout.json").string() + "</layout>\n";
}

// irpd on one.xml: module "a" (counter v1, 1 ms) journaling to a.log.  two.xml: module "b"
// (counter v2) on an <executor> of its own, with shared variables, which only a restart can bring in.
struct Cell {
    TempDir dir;
    std::string socket = (dir.path / "irpd.sock").string();
    std::string instance = uniqueInstance();
    std::unique_ptr<Process> irpd;

    Cell() {
        fs::copy_file(kModules / "counter_v1.so", dir.path / "a.so");
        fs::copy_file(kModules / "counter_v2.so", dir.path / "b.so");
        fs::copy_file(kModules / "init_throws.so", dir.path / "throws.so");
        write("one.xml", "<root>\n" + module("a", "a.so", 1'000'000, journal("a")) + "</root>\n");
        write("two.xml", "<root>\n" + variables() + "  <executor><name>side</name></executor>\n" +
                             module("b", "b.so", 2'000'000, journal("b") + "<executor>side</executor>") + "</root>\n");
        irpd = std::make_unique<Process>(std::vector<std::string>{kIrpd, "--config", (dir.path / "one.xml").string(),
                                                                  "--control-socket", socket, "--instance", instance,
                                                                  "--module-cache", (dir.path / "cache").string()},
                                         dir.path);
        EXPECT_TRUE(irpd->waitForErr("irpd: running")) << irpd->err();
    }
    ~Cell() {
        kill(irpd->pid(), SIGTERM);
        if (irpd->wait(std::chrono::seconds(10)) == -1) {
            kill(irpd->pid(), SIGKILL);
            irpd->wait(std::chrono::seconds(10));
        }
        removeShm(instance);
    }
    std::string journal(const std::string &name) {
        return "<property><value name=\"journal\">" + (dir.path / (name + ".log")).string() + "</value></property>";
    }
    void write(const std::string &name, const std::string &text) { std::ofstream(dir.path / name) << text; }
    std::string log(const std::string &name) { return readFile(dir.path / (name + ".log")); }
    std::string path(const std::string &name) { return (dir.path / name).string(); }

    // One request on a connection of its own (a restart closes every connection); null when irpd
    // does not answer (it is between its two images).
    json ask(const json &request) {
        Client client(socket, 10);
        if (!client.connected() || client.readLine().empty()) return nullptr;
        const std::string line = (client.sendRaw(request.dump() + "\n"), client.readLine());
        return line.empty() ? json(nullptr) : json::parse(line);
    }
    json result(const json &request) {
        json answer = ask(request);
        EXPECT_TRUE(answer.is_object() && answer.value("ok", false)) << request.dump() << " -> " << answer.dump();
        return answer.is_object() ? answer.value("result", json()) : json();
    }
    // irpd's status once `done` holds for it (at most 30 s), else null.
    json statusWhen(const std::function<bool(const json &)> &done) {
        const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
        while (std::chrono::steady_clock::now() < end) {
            json answer = ask({{"cmd", "status"}});
            if (answer.is_object() && answer.value("ok", false) && done(answer["result"])) return answer["result"];
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        return nullptr;
    }
    // The status of the image that answered the restart asked at `requested_ns`.
    json afterRestart(int64_t requested_ns) {
        return statusWhen([&](const json &s) {
            return s["last_restart"].is_object() && s["last_restart"]["requested_ns"] == requested_ns;
        });
    }
    uint64_t runsOf(const std::string &name) {
        for (const json &m : result({{"cmd", "modules"}}))
            if (m["name"] == name) return m.value("runs", uint64_t{0});
        return 0;
    }
    std::vector<json> events(const std::string &kind) {
        std::vector<json> found;
        const json answer = result({{"cmd", "events"}});
        for (const json &e : answer["events"])
            if (e["kind"] == kind) found.push_back(e);
        return found;
    }
};

}  // namespace

// A set that only a restart can run (shared variables on an irpd without them): refused online, run after the restart by
// the same process, with the downtime measured from the old set's last period to the new one's first.
TEST(ManagedRestart, TheSamePidRunsTheNewSetAndSaysItsDowntime) {
    Cell cell;
    const pid_t pid = cell.irpd->pid();
    const json checked = cell.result({{"cmd", "check"}, {"config", cell.path("two.xml")}});
    EXPECT_EQ(checked["valid"], true) << checked.dump();
    EXPECT_EQ(checked["online"], false) << checked.dump();
    ASSERT_TRUE(checked["restart"].is_object()) << checked.dump();
    EXPECT_GT(checked["restart"].value("expected_downtime_ns", int64_t{0}), 0) << "start-up + stop estimate";
    const json online = cell.ask({{"cmd", "load"}, {"config", cell.path("two.xml")}, {"set_id", "two"}});
    EXPECT_EQ(online["error"]["code"], "restart_required") << online.dump();

    const json asked = cell.result({{"cmd", "restart"}, {"config", cell.path("two.xml")}, {"set_id", "two"}});
    EXPECT_EQ(asked["restarting"], true);
    EXPECT_EQ(asked["pid"], pid);
    EXPECT_EQ(asked["set_id"], "two");
    EXPECT_TRUE(asked["from_set_id"].is_null()) << "irpd started on one.xml without a set id";
    EXPECT_GT(asked.value("expected_downtime_ns", int64_t{0}), 0);
    const json status = cell.afterRestart(asked["requested_ns"].get<int64_t>());
    ASSERT_TRUE(status.is_object()) << cell.irpd->err();

    // The same process: its pid, never exited, now on two.xml.
    EXPECT_EQ(status["pid"], pid);
    EXPECT_EQ(cell.irpd->wait(std::chrono::milliseconds(1)), -1) << "irpd exited: " << cell.irpd->err();
    EXPECT_EQ(status["set_id"], "two");
    EXPECT_EQ(status["set"], cell.path("two.xml"));
    EXPECT_EQ(status["generation"], 1);
    const json last = status["last_restart"];
    EXPECT_EQ(last["fell_back"], false) << last.dump();
    EXPECT_TRUE(last["error"].is_null()) << last.dump();
    EXPECT_EQ(last["set_id"], "two");
    EXPECT_GT(last.value("downtime_ns", int64_t{0}), 0) << last.dump();
    EXPECT_LT(last.value("downtime_ns", int64_t{0}), 10'000'000'000) << last.dump();
    std::cerr << "restart downtime " << last["downtime_ns"].get<int64_t>() / 1e6 << " ms (stop "
              << last["stop_ns"].get<int64_t>() / 1e6 << " ms, start-up " << last["startup_ns"].get<int64_t>() / 1e6
              << " ms)\n";

    // The old set was stopped as a clean stop does; the new one runs.
    EXPECT_TRUE(std::regex_match(cell.log("a"), std::regex("start v1\nstop v1 runs=[1-9][0-9]*\n"))) << cell.log("a");
    EXPECT_EQ(cell.log("b"), "start v2\n");
    const uint64_t runs = cell.runsOf("b");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    EXPECT_GT(cell.runsOf("b"), runs);
    const std::vector<json> restarts = cell.events("restart");
    ASSERT_EQ(restarts.size(), 1u);
    EXPECT_NE(restarts[0]["message"].get<std::string>().find("restarted onto set two: downtime "), std::string::npos)
        << restarts[0].dump();
    // The measured downtime is what the next restart expects.
    // (a layout laid out afresh: only a restart can replace oc_v1 with it)
    cell.write("three.xml", "<root>\n  <layout>" + (fs::path(ONLINE_DIR) / "oc_reordered" / "layout.json").string() +
                                "</layout>\n" + module("a", "a.so", 1'000'000) + "</root>\n");
    const json again = cell.result({{"cmd", "check"}, {"config", cell.path("three.xml")}});
    ASSERT_TRUE(again["restart"].is_object()) << again.dump();
    EXPECT_EQ(again["restart"]["expected_downtime_ns"], last["downtime_ns"]);

    kill(pid, SIGTERM);
    EXPECT_EQ(cell.irpd->wait(std::chrono::seconds(10)), 0) << cell.irpd->err();
    EXPECT_TRUE(std::regex_match(cell.log("b"), std::regex("start v2\nstop v2 runs=[1-9][0-9]*\n"))) << cell.log("b");
}

// A set whose module fails its initialize() at start: the same process comes back on the set it
// ran, once, and says so.
TEST(ManagedRestart, ASetThatDoesNotStartBringsBackTheSetThatRan) {
    Cell cell;
    const pid_t pid = cell.irpd->pid();
    cell.result({{"cmd", "load"}, {"config", cell.path("one.xml")}, {"set_id", "one"}});  // gives it its id
    cell.write("bad.xml", "<root>\n" + variables() + "  <executor><name>side</name></executor>\n" +
                              module("x", "throws.so", 1'000'000, "<executor>side</executor>") + "</root>\n");
    const json asked = cell.result({{"cmd", "restart"}, {"config", cell.path("bad.xml")}, {"set_id", "bad"}});
    EXPECT_EQ(asked["from_set_id"], "one");
    const json status = cell.afterRestart(asked["requested_ns"].get<int64_t>());
    ASSERT_TRUE(status.is_object()) << cell.irpd->err();
    EXPECT_EQ(status["pid"], pid);
    EXPECT_EQ(cell.irpd->wait(std::chrono::milliseconds(1)), -1) << cell.irpd->err();
    EXPECT_EQ(status["set_id"], "one");
    EXPECT_EQ(status["set"], cell.path("one.xml"));
    const json last = status["last_restart"];
    EXPECT_EQ(last["fell_back"], true) << last.dump();
    EXPECT_EQ(last["set_id"], "bad");
    EXPECT_EQ(last["from_set_id"], "one");
    EXPECT_NE(last.value("error", "").find("initialize"), std::string::npos) << last.dump();
    EXPECT_GT(last.value("downtime_ns", int64_t{0}), 0);
    const std::vector<json> failed = cell.events("restart_failed");
    ASSERT_EQ(failed.size(), 1u);
    EXPECT_NE(failed[0]["message"].get<std::string>().find("could not start set bad"), std::string::npos);
    EXPECT_NE(failed[0]["message"].get<std::string>().find("came back on set one"), std::string::npos);
    // a was stopped, then started again by the fallback image.
    EXPECT_TRUE(std::regex_match(cell.log("a"), std::regex("start v1\nstop v1 runs=[0-9]+\nstart v1\n")))
        << cell.log("a");
    const uint64_t runs = cell.runsOf("a");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    EXPECT_GT(cell.runsOf("a"), runs);
}

// A set refused for another reason than restart_required is refused at once, with its file:line,
// and nothing stops: the running module keeps counting, in the same generation.
TEST(ManagedRestart, ASetRefusedForAPlainReasonIsRefusedAndNothingStops) {
    Cell cell;
    cell.write("bad.xml", "<root>\n" + module("x", "a.so", 1'000'000) + "  <module><name>y</name></module>\n</root>\n");
    cell.write("nofile.xml", "<root>\n" + module("x", "nothere.so", 1'000'000) + "</root>\n");
    const json before = cell.result({{"cmd", "status"}});
    const uint64_t runs = cell.runsOf("a");
    struct Case {
        std::string file, expected;
    };
    for (const Case &c : {Case{"bad.xml", cell.path("bad.xml") + ":3"}, Case{"nofile.xml", "does not exist"}}) {
        const json answer = cell.ask({{"cmd", "restart"}, {"config", cell.path(c.file)}, {"set_id", "x"}});
        ASSERT_TRUE(answer.is_object()) << c.file;
        EXPECT_FALSE(answer.value("ok", true)) << c.file << ": " << answer.dump();
        EXPECT_EQ(answer["error"]["code"], "refused") << answer.dump();
        EXPECT_NE(answer["error"].value("message", "").find(c.expected), std::string::npos) << answer.dump();
    }
    const json missing = cell.ask({{"cmd", "restart"}});
    EXPECT_NE(missing["error"].value("message", "").find("'config' is required"), std::string::npos) << missing.dump();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const json after = cell.result({{"cmd", "status"}});
    EXPECT_EQ(after["generation"], before["generation"]);
    EXPECT_TRUE(after["last_restart"].is_null());
    EXPECT_GT(cell.runsOf("a"), runs + 50) << "a kept running every 1 ms";
    EXPECT_EQ(cell.log("a"), "start v1\n") << "never stopped";
    EXPECT_TRUE(cell.events("restart").empty());
}
