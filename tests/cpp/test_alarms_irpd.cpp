// test_alarms_irpd.cpp -- irpd's side of alarms (docs/alarms.md): the segment named in `status`,
// a thread module's and a process module's alarms in the ring and in the `alarms` answer with
// their declarations (module.xml's and the code's), a set refused for a conflicting declaration,
// and the sources across hot swaps: kept by name, a new name on a source neither set uses, a
// dropped name's source freed after the swap and given again later.
#include "alarms/alarm_segment.hpp"
#include "osal/shm.hpp"
#include "protocol/limits.hpp"
#include "support/alarm_ring.hpp"
#include "support/control_client.hpp"
#include "support/irpd.hpp"
#include "support/subprocess.hpp"

#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <thread>

using nlohmann::json;
using testing_support::AlarmRing;
using testing_support::Client;
using testing_support::kIrpd;
using testing_support::Process;
using testing_support::TempDir;
using testing_support::uniqueInstance;
namespace fs = std::filesystem;

namespace {

const fs::path kModules = FIXTURE_MODULES;
const std::string kAlarmProcess = std::string(FIXTURE_PROCESSES) + "/proc_alarm.exe";

std::string value(const std::string &name, const std::string &v) {
    return "<value name=\"" + name + "\">" + v + "</value>";
}

// A thread module `name` of alarming.so with its properties and <alarm> lines.
std::string alarming(const std::string &name, const std::string &properties, const std::string &alarms = "",
                     int priority = 1) {
    return "  <module><name>" + name +
           "</name><filename>./alarming.so</filename><moduletype>thread</moduletype>"
           "<operationtype>periodic</operationtype><period>2000000</period><priority>" +
           std::to_string(priority) + "</priority><property>" + properties + "</property>" + alarms + "</module>\n";
}

// irpd on module.xml in a scratch folder, with its control socket; "@DIR@" in the body stands for
// the folder.
struct Cell {
    TempDir dir;
    std::string socket = (dir.path / "irpd.sock").string();
    std::string instance = uniqueInstance();
    std::unique_ptr<Process> irpd;
    std::unique_ptr<Client> client;

    explicit Cell(std::string body) {
        for (std::size_t at; (at = body.find("@DIR@")) != std::string::npos;) body.replace(at, 5, dir.path.string());
        fs::copy_file(kModules / "alarming.so", dir.path / "alarming.so");
        write("module.xml", "<root>\n" + body + "</root>\n");
        irpd = std::make_unique<Process>(std::vector<std::string>{kIrpd, "--config", path("module.xml"),
                                                                  "--control-socket", socket, "--instance", instance,
                                                                  "--module-cache", path("cache")},
                                         dir.path);
    }
    bool started() {
        if (!irpd->waitForErr("irpd: running")) return false;
        client = std::make_unique<Client>(socket, 60);
        return !client->readLine().empty();  // the hello
    }
    ~Cell() {
        client.reset();
        kill(irpd->pid(), SIGTERM);
        irpd->wait(std::chrono::seconds(10));
    }
    std::string path(const std::string &name) const { return (dir.path / name).string(); }
    void write(const std::string &name, const std::string &text) const { std::ofstream(dir.path / name) << text; }
    json result(const json &request) {
        json answer = client->request(request);
        EXPECT_TRUE(answer.value("ok", false)) << request.dump() << " -> " << answer.dump();
        return answer.value("result", json());
    }
    // The `alarms` answer's source of `module`.
    json source(const std::string &module) {
        const json answer = result({{"cmd", "alarms"}});
        for (const json &s : answer["sources"])
            if (s["module"] == module) return s;
        return json();
    }
    // Polls `done` every 20 ms for up to 20 s.
    static bool waitUntil(const std::function<bool()> &done) {
        const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
        while (std::chrono::steady_clock::now() < end) {
            if (done()) return true;
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        return false;
    }
};

// Every record of the segment, read after the writers went quiet.
std::vector<indurop_alarm_record> records(const std::string &shm) {
    auto mapped = irp::osal::SharedMemory::open(shm, false);
    EXPECT_TRUE(mapped.ok()) << shm;
    if (!mapped.ok()) return {};
    const auto *h = static_cast<const indurop_alarm_header *>(mapped->data());
    std::vector<indurop_alarm_record> all;
    AlarmRing ring(h);
    for (uint64_t s = 1; s <= h->head; ++s)
        if (auto r = ring.read(s)) all.push_back(*r);
    return all;
}

}  // namespace

TEST(IrpdAlarms, AThreadAndAProcessModuleRaiseAndClearAndTheAnswerListsTheirDeclarations) {
    Cell cell(
        alarming("plc",
                 value("ids", "8 9") + value("trigger", "@DIR@/plc.on") + value("declare", "20 low From the code"),
                 R"(<alarm id="8" severity="high">drive communication lost</alarm>)") +
        "  <module><name>proc</name><filename>" + kAlarmProcess +
        "</filename><moduletype>process</moduletype><operationtype>periodic</operationtype>"
        "<period>2000000</period><priority>2</priority><property>" +
        value("args", "5 @DIR@/proc.on") + "</property>" + R"(<alarm id="5">pressure low</alarm>)" + "</module>\n");
    ASSERT_TRUE(cell.started()) << cell.irpd->err();

    const json status = cell.result({{"cmd", "status"}});
    EXPECT_EQ(status["shared_memory"]["alarms"], "/indurop." + cell.instance + ".alarms");
    json answer = cell.result({{"cmd", "alarms"}});
    EXPECT_EQ(answer["segment"], status["shared_memory"]["alarms"]);
    EXPECT_EQ(answer["rate_limit"], irp::protocol::kAlarmRateLimit);
    ASSERT_EQ(answer["sources"].size(), 3u);
    EXPECT_EQ(answer["sources"][0]["module"], "irpd");
    EXPECT_EQ(answer["sources"][0]["source"], 0);
    EXPECT_EQ(answer["sources"][1]["module"], "plc");
    EXPECT_EQ(answer["sources"][1]["source"], 1);
    EXPECT_EQ(answer["sources"][2]["module"], "proc");
    EXPECT_EQ(answer["sources"][2]["source"], 2);
    EXPECT_EQ(answer["sources"][1]["declared"],
              json::parse(R"([{"id": 8, "severity": "high", "text": "drive communication lost", "origin": "module.xml"},
                              {"id": 20, "severity": "low", "text": "From the code", "origin": "code"}])"));
    EXPECT_EQ(answer["sources"][2]["declared"],
              json::parse(R"([{"id": 5, "severity": "medium", "text": "pressure low", "origin": "module.xml"}])"));
    EXPECT_EQ(answer["sources"][1]["active"], json::array());
    // A process may not declare in code: module.xml is its place.
    EXPECT_TRUE(cell.irpd->waitForOut("declareAlarm: irp::declareAlarm(5): a process module declares its alarms in "
                                      "module.xml"))
        << cell.irpd->out();

    cell.write("plc.on", "");
    cell.write("proc.on", "");
    ASSERT_TRUE(Cell::waitUntil([&] {
        return cell.source("plc")["active"] == json::array({8, 9}) && cell.source("proc")["active"] == json::array({5});
    })) << cell.result({{"cmd", "alarms"}}).dump();
    fs::remove(cell.dir.path / "plc.on");
    fs::remove(cell.dir.path / "proc.on");
    ASSERT_TRUE(
        Cell::waitUntil([&] { return cell.source("plc")["active"].empty() && cell.source("proc")["active"].empty(); }));
    const json plc = cell.source("plc"), proc = cell.source("proc");
    EXPECT_EQ(plc["recorded"], 4);    // 8 and 9 raised once and cleared once, however many periods
    EXPECT_EQ(plc["undeclared"], 2);  // 9
    EXPECT_EQ(proc["recorded"], 2);
    EXPECT_EQ(proc["undeclared"], 0);

    const auto all = records(status["shared_memory"]["alarms"]);
    ASSERT_EQ(all.size(), 6u);
    bool process_raise = false;
    for (const indurop_alarm_record &r : all) {
        EXPECT_GT(r.cycle, 0u) << r.id;  // written in a dispatched period
        if (r.source == 2 && r.action == INDUROP_ALARM_RAISE) {
            process_raise = true;
            EXPECT_EQ(r.id, 5u);
            EXPECT_STREQ(r.text, "from a process");
            EXPECT_EQ(r.value, 42);
            EXPECT_EQ(r.source_generation, proc["generation"].get<uint64_t>());
        }
        if (r.source == 1 && r.id == 9) {
            EXPECT_EQ(r.flags, INDUROP_ALARM_UNDECLARED);
        }
        if (r.source == 1 && r.action == INDUROP_ALARM_RAISE) {
            EXPECT_EQ(std::string(r.text).rfind("run ", 0), 0u) << r.text;
        }
    }
    EXPECT_TRUE(process_raise);
}

TEST(IrpdAlarms, ACodeDeclarationThatContradictsModuleXmlRefusesTheSet) {
    Cell cell(alarming("plc", value("declare", "8 high comm lost"),
                       R"(<alarm id="8" severity="high">drive communication lost</alarm>)"));
    EXPECT_EQ(cell.irpd->wait(std::chrono::seconds(30)), 2) << cell.irpd->err();  // the set is refused
    EXPECT_NE(cell.irpd->err().find("alarm 8 is declared already in module.xml as 'drive communication lost'"),
              std::string::npos)
        << cell.irpd->err();
}

// Sources go by module name; a swap never gives a new module a source a running one still has.
TEST(IrpdAlarms, SourcesFollowModuleNamesAcrossSwaps) {
    Cell cell(alarming("x", value("ids", "1") + value("toggle_every", "1000000")) + alarming("y", value("ids", "1")));
    ASSERT_TRUE(cell.started()) << cell.irpd->err();
    const json x = cell.source("x"), y = cell.source("y");
    ASSERT_TRUE(x.is_object() && y.is_object()) << cell.result({{"cmd", "alarms"}}).dump() << cell.irpd->err();
    EXPECT_EQ(x["source"], 1);
    EXPECT_EQ(y["source"], 2);
    auto load = [&](const std::string &file, const std::string &body) {
        cell.write(file, "<root>\n" + body + "</root>\n");
        return cell.result({{"cmd", "load"}, {"config", cell.path(file)}});
    };
    // z comes first in the file and y goes: x keeps 1, z takes 3 (y still has 2 until the swap).
    load("b.xml",
         alarming("z", value("ids", "1")) + alarming("x", value("ids", "1") + value("toggle_every", "1000000")));
    json answer = cell.result({{"cmd", "alarms"}});
    ASSERT_EQ(answer["sources"].size(), 3u);
    EXPECT_EQ(cell.source("x")["source"], 1);
    EXPECT_EQ(cell.source("x")["generation"], x["generation"]);  // the same module: the same generation
    EXPECT_EQ(cell.source("z")["source"], 3);
    EXPECT_TRUE(cell.source("y").is_null());
    // y's source was freed after the swap: all zero; a later new name takes it.
    {
        auto mapped = irp::osal::SharedMemory::open(answer["segment"], false);
        ASSERT_TRUE(mapped.ok());
        const auto *h = static_cast<const indurop_alarm_header *>(mapped->data());
        const auto &s2 =
            reinterpret_cast<const indurop_alarm_source *>(reinterpret_cast<const char *>(h) + h->sources_offset)[2];
        EXPECT_STREQ(s2.name, "");
        EXPECT_EQ(s2.generation, 0u);
    }
    load("c.xml",
         alarming("w", value("ids", "1")) + alarming("x", value("ids", "1") + value("toggle_every", "1000000")));
    EXPECT_EQ(cell.source("w")["source"], 2);
    EXPECT_GT(cell.source("w")["generation"].get<uint64_t>(), cell.source("x")["generation"].get<uint64_t>());
    EXPECT_EQ(cell.source("x")["source"], 1);
    // x loaded anew (its properties changed): the same source, its alarms and counters kept.
    load("d.xml", alarming("x", value("ids", "1 2") + value("toggle_every", "1000000")));
    EXPECT_EQ(cell.source("x")["source"], 1);
    EXPECT_EQ(cell.result({{"cmd", "alarms"}})["sources"].size(), 2u);
}
