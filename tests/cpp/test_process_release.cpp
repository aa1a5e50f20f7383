// test_process_release.cpp -- a periodic process module is never running before its release, in
// the slot's priority order, across skipped slots, with irpd's fast release (no FUTEX_WAKE when the
// process's own timer has already ended its wait, docs/process-modules.md) and when it must be
// woken: the real irpd, a thread module writing a shared variable in every slot (tick_writer.so)
// and a process checking it (tick_reader.exe), one after the other in the slot, both ways round.
// The writer pauses (sleeps) before writing every 3rd run, so that the process, whose timer has
// fired, gets the CPU before its release and must then be woken; a third module stalls past the
// basic period every 150th run, so that slots are skipped (--overrun-policy skip).
#include "support/irpd.hpp"
#include "support/subprocess.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>

using nlohmann::json;
using testing_support::kIrpd;
using testing_support::Process;
using testing_support::readFile;
using testing_support::TempDir;
using testing_support::uniqueInstance;
namespace fs = std::filesystem;

namespace {

const fs::path kFixtures = FIXTURE_PROCESSES;
constexpr const char *kPeriod = "2000000";  // 2 ms: room for the writer's pause on a busy machine

std::string thread(const std::string &name, int priority, const std::string &values) {
    return "  <module><name>" + name + "</name><filename>./" + name +
           ".so</filename><moduletype>thread</moduletype><operationtype>periodic</operationtype><period>" + kPeriod +
           "</period><priority>" + std::to_string(priority) + "</priority><property>" + values +
           "</property></module>\n";
}

std::string value(const std::string &name, const std::string &v) {
    return "<value name=\"" + name + "\">" + v + "</value>";
}

struct Outcome {
    std::map<std::string, json> modules;  // --stats-json's records by name
    json dispatcher;
    std::string out;
};

// irpd for 3 s on writer, reader and staller, the reader at `reader_priority` (1: first in the slot).
Outcome runSet(int reader_priority, const char *reader_args) {
    TempDir dir;
    for (const char *copy : {"writer.so", "staller.so"})  // two files: two instances of the module's globals
        fs::copy_file(kFixtures / "tick_writer.so", dir.path / copy);
    const std::string set =
        "<root>\n  <layout>" + std::string(TEST_VARS_LAYOUT) + "</layout>\n" +
        thread("writer", reader_priority == 1 ? 2 : 1, value("pause_every", "3") + value("pause_us", "300")) +
        "  <module><name>reader</name><filename>" + (kFixtures / "tick_reader.exe").string() +
        "</filename><moduletype>process</moduletype><operationtype>periodic</operationtype><period>" + kPeriod +
        "</period><priority>" + std::to_string(reader_priority) + "</priority><property>" + value("args", reader_args) +
        value("restart", "never") + "</property></module>\n" +
        thread("staller", 3, value("write", "0") + value("stall_every", "150") + value("stall_us", "5000")) +
        "</root>\n";
    std::ofstream(dir.path / "module.xml") << set;
    const std::string stats = (dir.path / "stats.json").string();
    Process irpd({kIrpd, "--config", (dir.path / "module.xml").string(), "--duration", "3", "--overrun-policy", "skip",
                  "--stats-json", stats, "--instance", uniqueInstance()},
                 dir.path);
    Outcome o;
    EXPECT_EQ(irpd.wait(std::chrono::seconds(60)), 0) << irpd.err();
    o.out = irpd.out();
    const json s = json::parse(readFile(stats));
    for (const json &m : s["modules"]) o.modules[m["name"]] = m;
    o.dispatcher = s["dispatcher"];
    return o;
}

// What both orders must show: the process checked every release it served and found nothing wrong,
// it served every release irpd counted, it kept being released (a release that was not woken would
// have left it waiting for good), and slots were skipped meanwhile.
void expectReleasedOnlyWhenDue(const Outcome &o) {
    const uint64_t runs = o.modules.at("reader")["runs"].get<uint64_t>();
    EXPECT_NE(o.out.find("[reader] tick_reader: releases=" + std::to_string(runs) + " bad=0"), std::string::npos)
        << "irpd counted " << runs << " releases\n"
        << o.out;
    EXPECT_GT(runs * 2, o.modules.at("writer")["runs"].get<uint64_t>()) << o.out;
    EXPECT_GT(o.dispatcher["skipped"].get<uint64_t>(), 0u) << "the staller made no slot skip: the test saw none";
}

}  // namespace

TEST(ProcessRelease, AfterAThreadModuleItSeesThatModulesWriteOfItsSlotAndNeverRunsBeforeItsRelease) {
    expectReleasedOnlyWhenDue(runSet(2, "--after"));
}

TEST(ProcessRelease, FirstInItsSlotItIsReleasedBeforeTheThreadModulesAndOnlyInItsSlot) {
    expectReleasedOnlyWhenDue(runSet(1, "--first"));
}
