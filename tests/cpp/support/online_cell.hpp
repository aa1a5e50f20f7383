// online_cell.hpp -- irpd started on the online-change fixtures' v1 layout with the counter module,
// its control socket, and its shared variables mapped in the test (test_online_change,
// test_forces_irpd): module.xml entries for the fixtures' thread and process modules, loads, reads.
#pragma once

#include "control_client.hpp"
#include "irpd.hpp"
#include "subprocess.hpp"

#include <indurop/process.h>
#include <indurop/shared.h>

#include <gtest/gtest.h>

#include <signal.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <thread>

namespace online_cell {
using nlohmann::json;
using testing_support::Client;
using testing_support::kIrpd;
using testing_support::Process;
using testing_support::readFile;
using testing_support::TempDir;
using testing_support::uniqueInstance;
namespace fs = std::filesystem;

const fs::path kOnline = ONLINE_DIR;

inline std::string layoutOf(const std::string &name) { return (kOnline / ("oc_" + name) / "layout.json").string(); }

inline std::string thread(const std::string &name, const std::string &file, const fs::path &dir, int priority = 1,
                          const std::string &extra = "", int64_t period_ns = 1'000'000) {
    return "  <module><name>" + name + "</name><filename>" + (kOnline / "modules" / file).string() +
           "</filename><moduletype>thread</moduletype><operationtype>periodic</operationtype>"
           "<period>" +
           std::to_string(period_ns) + "</period><priority>" + std::to_string(priority) +
           "</priority><property><value name=\"journal\">" + (dir / (name + ".log")).string() + "</value></property>" +
           extra + "</module>\n";
}

inline std::string process(const std::string &name, const std::string &file, int priority = 5) {
    return "  <module><name>" + name + "</name><filename>" + (kOnline / "modules" / file).string() +
           "</filename><moduletype>process</moduletype><operationtype>periodic</operationtype>"
           "<period>2000000</period><priority>" +
           std::to_string(priority) + "</priority></module>\n";
}

// irpd on the v1 layout with the counter module, its control socket, and the segment mapped here.
struct Cell {
    TempDir dir;
    std::string socket = (dir.path / "irpd.sock").string();
    std::string instance = uniqueInstance();
    std::unique_ptr<Process> irpd;
    std::unique_ptr<Client> client;
    channel::Handle vars;

    // Starts on layout `start_layout` with the module `first` (name, file) and `modules`.
    explicit Cell(const std::string &modules = "", std::vector<std::string> extra = {},
                  const std::string &start_layout = "v1",
                  const std::pair<std::string, std::string> &first = {"counter", "oc_counter_v1.so"}) {
        writeSet("start.xml", start_layout, thread(first.first, first.second, dir.path) + modules);
        std::vector<std::string> args{kIrpd,
                                      "--config",
                                      (dir.path / "start.xml").string(),
                                      "--control-socket",
                                      socket,
                                      "--instance",
                                      instance,
                                      "--module-cache",
                                      (dir.path / "cache").string(),
                                      "--stats-json",
                                      (dir.path / "stats.json").string()};
        args.insert(args.end(), extra.begin(), extra.end());
        irpd = std::make_unique<Process>(args, dir.path);
        EXPECT_TRUE(irpd->waitForErr("irpd: running")) << irpd->err();
        client = std::make_unique<Client>(socket, 60);
        EXPECT_FALSE(client->readLine().empty());  // the hello
        EXPECT_EQ(irp::shared::attach("/indurop." + instance + ".vars", false), "");
    }
    ~Cell() {
        irp::shared::detach();
        client.reset();
        kill(irpd->pid(), SIGTERM);
        irpd->wait(std::chrono::seconds(10));
    }
    // A module.xml naming `layout` (a folder of kOnline) and the modules.
    std::string writeSet(const std::string &file, const std::string &layout, const std::string &modules) {
        std::ofstream(dir.path / file) << "<root>\n  <layout>" << layoutOf(layout) << "</layout>\n"
                                       << modules << "</root>\n";
        return (dir.path / file).string();
    }
    json ask(const json &request) { return client->request(request); }
    json load(const std::string &xml) { return ask({{"cmd", "load"}, {"config", xml}}); }
    uint64_t u64(const char *path) {
        uint64_t v = 0;
        EXPECT_EQ(read(vars, path, sizeof v, &v), static_cast<int>(sizeof v)) << path;
        return v;
    }
    double f64(const char *path) { return value<double>(path); }
    template <class T>
    T value(const char *path) {
        T v{};
        EXPECT_EQ(read(vars, path, sizeof v, &v), static_cast<int>(sizeof v)) << path;
        return v;
    }
    std::string log(const std::string &name) { return readFile(dir.path / (name + ".log")); }
    json generation() { return ask({{"cmd", "status"}})["result"]["generation"]; }

    // At the end: the counter module was one instance whose runs + skipped cover every period.
    void expectCounterMissedNoPeriod() {
        kill(irpd->pid(), SIGTERM);
        ASSERT_EQ(irpd->wait(std::chrono::seconds(10)), 0) << irpd->err();
        std::smatch m;
        const std::string journal = log("counter");
        ASSERT_TRUE(std::regex_match(journal, m, std::regex("start\nstop runs=([0-9]+)\n"))) << journal;
        const json stats = json::parse(readFile(dir.path / "stats.json"));
        const json &counter = stats["modules"][0];
        ASSERT_EQ(counter["name"], "counter");
        EXPECT_EQ(std::stoull(m[1]), counter["runs"].get<uint64_t>());
        const json &dispatcher = stats["dispatcher"];
        EXPECT_EQ(counter["runs"].get<uint64_t>() + counter["skipped"].get<uint64_t>(),
                  dispatcher["runs"].get<uint64_t>() + dispatcher["skipped"].get<uint64_t>());
    }
};

inline void settle() { std::this_thread::sleep_for(std::chrono::milliseconds(200)); }

}  // namespace online_cell
