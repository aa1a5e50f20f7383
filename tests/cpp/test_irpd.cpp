// test_irpd.cpp -- the irpd binary from outside: --print-schedule, refusals (exit 2, nothing
// started), timed runs with --stats-json, clean stop on SIGTERM/SIGINT, the non-RT fallback.
#include "osal/shm.hpp"
#include "shm/layout_json.hpp"
#include "stats/stats_block.hpp"
#include "stats/summary.hpp"
#include "support/irpd.hpp"
#include "support/subprocess.hpp"

#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <regex>

using nlohmann::json;
using testing_support::kFig1;
using testing_support::kIrpd;
using testing_support::Process;
using testing_support::readFile;
using testing_support::TempDir;
using testing_support::uniqueInstance;

namespace {

bool shmExists(const std::string &instance) {
    return std::filesystem::exists("/dev/shm/indurop." + instance + ".stats");
}

void writeFile(const std::filesystem::path &p, const std::string &text) { std::ofstream(p) << text; }

std::string module(const std::string &file, int64_t period, int priority, const std::string &extra = "") {
    return "  <module>\n    <filename>" + file +
           "</filename>\n    <moduletype>thread</moduletype>\n    <operationtype>periodic</operationtype>\n"
           "    <period>" +
           std::to_string(period) + "</period>\n    <priority>" + std::to_string(priority) + "</priority>\n" + extra +
           "  </module>\n";
}

// A module of the paper-fig1 set, with the set's layout.json beside it (the modules use its variables).
void copyFig1Module(const std::string &file, const TempDir &dir) {
    const std::string set = std::string(BUILD_ROOT) + "/sets/paper-fig1/";
    std::filesystem::copy_file(set + file, dir.path / file);
    if (!std::filesystem::exists(dir.path / "layout.json"))
        std::filesystem::copy_file(set + "layout.json", dir.path / "layout.json");
}

struct Outcome {
    int status;
    std::string out, err;
};

// Runs irpd to its end.  A run that may create shared memory gets an instance of its own, so that
// tests never meet each other (or a demo) on the default one.
Outcome irpd(std::vector<std::string> args, const TempDir &dir, std::chrono::seconds limit = std::chrono::seconds(60)) {
    const bool has_config = std::find(args.begin(), args.end(), "--config") != args.end();
    const bool has_instance = std::find(args.begin(), args.end(), "--instance") != args.end();
    if (has_config && !has_instance) args.insert(args.begin(), {"--instance", uniqueInstance()});
    args.insert(args.begin(), kIrpd);
    Process p(args, dir.path);
    int status = p.wait(limit);
    return {status, p.out(), p.err()};
}

}  // namespace

TEST(IrpdPrintSchedule, Figure1IsTable3) {
    TempDir dir;
    Outcome r = irpd({"--config", kFig1, "--print-schedule"}, dir);
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.out, "basic period 100000 ns (100 us), macro period 500000 ns (500 us), 5 slots\n"
                     "slot  offset_ns    modules (in priority order)\n"
                     "0     0            cntr3 > cntr2 > cntr1 > cntr4\n"
                     "1     100000       cntr3 > cntr2\n"
                     "2     200000       cntr3 > cntr2\n"
                     "3     300000       cntr3 > cntr2\n"
                     "4     400000       cntr3 > cntr2\n"
                     "outside the slot table:\n"
                     "  event1 (sporadic thread, deadline 1000000 ns, priority 1, checked every basic period)\n"
                     "  visionEvt (sporadic process, deadline 100000000 ns, priority 2, checked every basic period)\n"
                     "  nonReaTime (non-real process, runs in the time left over)\n");
}

TEST(IrpdPrintSchedule, Figure1AsJson) {
    TempDir dir;
    Outcome r = irpd({"--config", kFig1, "--print-schedule", "--json"}, dir);
    ASSERT_EQ(r.status, 0) << r.err;
    json j = json::parse(r.out);
    EXPECT_EQ(j["basic_period_ns"], 100000);
    EXPECT_EQ(j["macro_period_ns"], 500000);
    ASSERT_EQ(j["slots"].size(), 5u);
    EXPECT_EQ(j["slots"][0], json::parse(R"({"index":0,"offset_ns":0,"modules":["cntr3","cntr2","cntr1","cntr4"]})"));
    for (int i = 1; i < 5; ++i)
        EXPECT_EQ(j["slots"][i], (json{{"index", i}, {"offset_ns", i * 100000}, {"modules", {"cntr3", "cntr2"}}}));
    // The key order of the issue: basic, macro, slots.
    EXPECT_LT(r.out.find("basic_period_ns"), r.out.find("macro_period_ns"));
    EXPECT_LT(r.out.find("macro_period_ns"), r.out.find("\"slots\""));
}

TEST(IrpdPrintSchedule, BasicPeriodBelowTheConfiguredMinimumIsRefused) {
    TempDir dir;
    Outcome r = irpd({"--config", kFig1, "--print-schedule", "--min-basic-period", "200000"}, dir);
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(
        r.err.find("the basic period (GCD of the periods) is 100000 ns, below the minimum basic period of 200000 ns"),
        std::string::npos)
        << r.err;
}

TEST(IrpdRefuses, MalformedXmlWithFileLineAndNothingStarted) {
    TempDir dir;
    const std::string instance = uniqueInstance();
    writeFile(dir.path / "module.xml",
              "<root>\n" + module("./a.so", 100000, 1) + "  <module>\n    <filename>./b.so\n</root>\n");
    Outcome r = irpd({"--config", (dir.path / "module.xml").string(), "--instance", instance}, dir);
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(std::regex_search(r.err, std::regex("module\\.xml:[0-9]+: malformed XML"))) << r.err;
    EXPECT_EQ(r.err.find("running"), std::string::npos);
    EXPECT_FALSE(shmExists(instance));
}

TEST(IrpdRefuses, BadPeriodNamesLineModuleAndField) {
    TempDir dir;
    writeFile(dir.path / "module.xml",
              "<root>\n" + module("./a.so", 100000, 1) +
                  "  <module>\n    <filename>./b.so</filename>\n    <moduletype>thread</moduletype>\n"
                  "    <operationtype>periodic</operationtype>\n    <period>-5</period>\n"
                  "    <priority>2</priority>\n  </module>\n</root>\n");
    Outcome r = irpd({"--config", (dir.path / "module.xml").string()}, dir);
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("module.xml:13: module 'b': <period>: '-5' must be greater than 0"), std::string::npos)
        << r.err;
}

TEST(IrpdRefuses, MissingModuleFileAndNothingStarted) {
    TempDir dir;
    const std::string instance = uniqueInstance();
    copyFig1Module("cntr1.so", dir);
    writeFile(dir.path / "module.xml",
              "<root>\n" + module("./cntr1.so", 100000, 1) + module("./gone.so", 100000, 2) + "</root>\n");
    Outcome r = irpd({"--config", (dir.path / "module.xml").string(), "--instance", instance}, dir);
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("module.xml:9: module 'gone': <filename> ./gone.so"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("does not exist"), std::string::npos) << r.err;
    EXPECT_EQ(r.out.find("[cntr1]"), std::string::npos) << r.out;  // not even initialized
    EXPECT_FALSE(shmExists(instance));
}

TEST(IrpdRefuses, InitializeFailureStartsNothing) {
    TempDir dir;
    copyFig1Module("cntr1.so", dir);
    writeFile(dir.path / "module.xml", "<root>\n" + module("./cntr1.so", 100000, 1) +
                                           module(std::string(FIXTURE_MODULES) + "/init_throws.so", 100000, 2) +
                                           "</root>\n");
    Outcome r = irpd({"--config", (dir.path / "module.xml").string()}, dir);
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("module 'init_throws': initialize() failed: calibration table missing"), std::string::npos)
        << r.err;
    EXPECT_NE(r.out.find("[cntr1] initialize"), std::string::npos);
    EXPECT_EQ(r.out.find("[cntr1] start"), std::string::npos);
}

// A step late in the start-up fails (the control socket's folder does not exist): everything built
// before it is released in reverse order -- the process stopped, then the started thread module's
// stop() -- no shared memory of the instance is left, and irpd exits 1 naming the cause.
TEST(IrpdRefuses, ALateStartFailureReleasesWhatWasBuiltInReverse) {
    TempDir dir;
    const std::string instance = uniqueInstance();
    copyFig1Module("cntr1.so", dir);
    copyFig1Module("cntr4.exe", dir);
    writeFile(
        dir.path / "module.xml",
        "<root>\n" + module("./cntr1.so", 100000, 1) +
            "  <module>\n    <filename>./cntr4.exe</filename>\n    <moduletype>process</moduletype>\n"
            "    <operationtype>periodic</operationtype>\n    <period>500000</period>\n    <priority>4</priority>\n"
            "  </module>\n</root>\n");
    const std::string socket = (dir.path / "missing" / "irpd.sock").string();
    Outcome r =
        irpd({"--config", (dir.path / "module.xml").string(), "--instance", instance, "--control-socket", socket}, dir);
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_NE(r.err.find("irpd: error: control socket " + socket + ": No such file or directory"), std::string::npos)
        << r.err;
    EXPECT_EQ(r.err.find("irpd: running"), std::string::npos) << r.err;
    const std::size_t started = r.out.find("[cntr1] start"),
                      process_stopped = r.out.find("[cntr4] cntr4: stop after 0 periods"),
                      module_stopped = r.out.find("[cntr1] stop after 0 runs");
    ASSERT_NE(started, std::string::npos) << r.out;
    ASSERT_NE(process_stopped, std::string::npos) << r.out;
    ASSERT_NE(module_stopped, std::string::npos) << r.out;
    EXPECT_LT(started, process_stopped);
    EXPECT_LT(process_stopped, module_stopped) << r.out;
    for (const auto &entry : std::filesystem::directory_iterator("/dev/shm"))
        EXPECT_NE(entry.path().filename().string().rfind("indurop." + instance + ".", 0), 0u)
            << entry.path() << " left behind";
}

TEST(IrpdOptions, HelpAndBadOptions) {
    TempDir dir;
    Outcome help = irpd({"--help"}, dir);
    EXPECT_EQ(help.status, 0);
    EXPECT_NE(help.out.find("--print-schedule"), std::string::npos);
    struct Case {
        std::vector<std::string> args;
        std::string message;
    };
    for (const Case &c :
         {Case{{"--bogus"}, "unknown option --bogus"}, Case{{}, "--config FILE.xml is required"},
          Case{{"--config", kFig1, "--json"}, "--json goes with --print-schedule"},
          Case{{"--config", kFig1, "--rt-priority", "200"}, "--rt-priority: '200' is not an integer from 1 to 99"},
          Case{{"--config", kFig1, "--duration", "-1"}, "--duration: '-1' is not a positive number"},
          Case{{"--config", kFig1, "--overrun-policy", "later"}, "expected catch-up or skip"},
          Case{{"--config", kFig1, "--instance", "../x"}, "--instance: '../x'"},
          Case{{"--config", kFig1, "--cpu"}, "needs a value"}}) {
        Outcome r = irpd(c.args, dir);
        EXPECT_EQ(r.status, 2) << c.message;
        EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
    }
}

TEST(IrpdRun, Figure1ForADurationGivesExactRunCountsAndStats) {
    TempDir dir;
    const std::string instance = uniqueInstance();
    const auto stats_path = dir.path / "stats.json";
    Outcome r = irpd(
        {"--config", kFig1, "--duration", "1.2", "--stats-json", stats_path.string(), "--instance", instance}, dir);
    ASSERT_EQ(r.status, 0) << r.err;
    json s = json::parse(readFile(stats_path));
    EXPECT_EQ(s["basic_period_ns"], 100000);
    EXPECT_EQ(s["macro_period_ns"], 500000);
    const json &d = s["dispatcher"];
    EXPECT_EQ(d["name"], "dispatcher");
    EXPECT_TRUE(s["stats_dropped"].is_number_unsigned());  // runs whose figures a full sample ring lost
    EXPECT_EQ(d["runs"].get<uint64_t>() + d["skipped"].get<uint64_t>(), 12000u);
    for (const char *key : {"jitter_ns", "exec_ns", "latency_ns"})
        for (const char *f : {"min", "max", "mean", "p50", "p99", "p999"}) EXPECT_TRUE(d[key].contains(f)) << key << f;

    std::map<std::string, json> by_name;
    for (const json &m : s["modules"]) by_name[m["name"]] = m;
    const std::map<std::string, uint64_t> expected = {{"cntr1", 2400}, {"cntr2", 12000}, {"cntr3", 12000}};
    for (const auto &[name, runs] : expected) {
        const json &m = by_name.at(name);
        EXPECT_EQ(m["state"], "stopped");
        EXPECT_EQ(m["runs"].get<uint64_t>() + m["skipped"].get<uint64_t>(), runs) << name;
        EXPECT_EQ(m["jitter_ns"]["count"], m["runs"]);  // folded from the dispatcher's samples by the stats thread
        EXPECT_EQ(m["latency_ns"]["count"], m["runs"]);
        EXPECT_EQ(m["exec_ns"]["count"], m["runs"]);
        // What the module itself counted (printed by its stop()) is what the dispatcher counted.
        EXPECT_NE(r.out.find("[" + name + "] stop after " + std::to_string(m["runs"].get<uint64_t>()) + " runs"),
                  std::string::npos)
            << r.out;
    }
    // event1 (Figure 7) fires when cntr3 has turned joint[0].x to 180 degrees, 3600 runs of 0.05,
    // and resets it: three times in 12000 runs, in the slot where the condition turned true.
    if (by_name.at("cntr3")["skipped"] == 0) {
        EXPECT_EQ(by_name.at("event1")["runs"], 3);
    }
    EXPECT_EQ(by_name.at("event1")["missed"], 0);
    // The processes: cntr4 (periodic, released and awaited in slot 0 of each macro period),
    // visionEvt (sporadic: released every basic period, Figure 8) and nonReaTime (non-real).
    const json &cntr4 = by_name.at("cntr4");
    EXPECT_EQ(cntr4["state"], "stopped");
    EXPECT_GT(cntr4["runs"].get<uint64_t>(), 0u);
    EXPECT_LE(cntr4["runs"].get<uint64_t>() + cntr4["skipped"].get<uint64_t>(), 2400u);
    EXPECT_NE(r.out.find("[cntr4] cntr4: stop after " + std::to_string(cntr4["runs"].get<uint64_t>()) + " periods"),
              std::string::npos)
        << r.out;  // every release the dispatcher counted, the process served
    EXPECT_GT(by_name.at("visionEvt")["runs"].get<uint64_t>(), 0u);
    EXPECT_EQ(by_name.at("nonReaTime")["runs"], 0);  // not dispatched: it runs in the time left over
    for (const char *name : {"cntr4", "visionEvt", "nonReaTime"})
        EXPECT_NE(r.out.find(std::string("process module '") + name + "' (pid "), std::string::npos) << name;
    EXPECT_NE(r.out.find("[cntr1] initialize: counter starts at 5"), std::string::npos);  // the XML's property
    EXPECT_FALSE(shmExists(instance));
}

namespace {

void stopsCleanlyOn(int signal) {
    TempDir dir;
    const std::string instance = uniqueInstance();
    const auto stats_path = dir.path / "stats.json";
    Process p({kIrpd, "--config", kFig1, "--stats-json", stats_path.string(), "--instance", instance}, dir.path);
    ASSERT_TRUE(p.waitForErr("irpd: running")) << p.err();
    EXPECT_TRUE(shmExists(instance));
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    kill(p.pid(), signal);
    ASSERT_EQ(p.wait(std::chrono::seconds(10)), 0) << p.err();
    for (const char *line : {"[cntr1] stop after", "[cntr2] stop after", "[cntr3] stop after"})
        EXPECT_NE(p.out().find(line), std::string::npos) << p.out();
    EXPECT_NE(p.err().find(signal == SIGINT ? "received SIGINT" : "received SIGTERM"), std::string::npos);
    json s = json::parse(readFile(stats_path));
    EXPECT_GT(s["dispatcher"]["runs"].get<uint64_t>(), 1000u);
    EXPECT_FALSE(shmExists(instance));
}

}  // namespace

TEST(IrpdRun, SigtermStopsEveryModuleAndUnloads) { stopsCleanlyOn(SIGTERM); }
TEST(IrpdRun, SigintStopsEveryModuleAndUnloads) { stopsCleanlyOn(SIGINT); }

TEST(IrpdRun, SecondIrpdOnTheSameInstanceIsRefused) {
    TempDir dir, dir2;
    const std::string instance = uniqueInstance();
    Process first({kIrpd, "--config", kFig1, "--instance", instance}, dir.path);
    ASSERT_TRUE(first.waitForErr("irpd: running")) << first.err();
    Outcome second = irpd({"--config", kFig1, "--instance", instance}, dir2);
    EXPECT_EQ(second.status, 1);
    EXPECT_NE(second.err.find("instance '" + instance + "' is in use by irpd pid " + std::to_string(first.pid())),
              std::string::npos)
        << second.err;
    kill(first.pid(), SIGTERM);
    EXPECT_EQ(first.wait(std::chrono::seconds(10)), 0);
}

TEST(IrpdRun, WithoutRtPrivilegesItRunsSchedOtherAndSaysSo) {
    if (access("/usr/bin/setpriv", X_OK) != 0) GTEST_SKIP() << "setpriv (util-linux) is needed to drop capabilities";
    TempDir dir;
    const auto stats_path = dir.path / "stats.json";
    // No capabilities at all (so no CAP_SYS_NICE) and RLIMIT_RTPRIO 0: SCHED_FIFO is refused.
    Process p({"/usr/bin/setpriv", "--inh-caps=-all", "--bounding-set=-all", "--", "/usr/bin/prlimit", "--rtprio=0",
               kIrpd, "--config", kFig1, "--duration", "0.5", "--stats-json", stats_path.string(), "--instance",
               uniqueInstance()},
              dir.path);
    ASSERT_EQ(p.wait(), 0) << p.err();
    EXPECT_NE(p.err().find("SCHED_FIFO refused"), std::string::npos) << p.err();
    EXPECT_NE(p.err().find("NOT REAL-TIME"), std::string::npos) << p.err();
    json s = json::parse(readFile(stats_path));
    EXPECT_EQ(s["realtime"], false);
    EXPECT_EQ(s["dispatcher"]["runs"].get<uint64_t>() + s["dispatcher"]["skipped"].get<uint64_t>(), 5000u);
}

TEST(IrpdRun, RealTimeStatsSayRealtimeWhenPrivileged) {
    if (geteuid() != 0) GTEST_SKIP() << "needs root or CAP_SYS_NICE";
    TempDir dir;
    const auto stats_path = dir.path / "stats.json";
    Outcome r = irpd(
        {"--config", kFig1, "--duration", "0.2", "--stats-json", stats_path.string(), "--instance", uniqueInstance()},
        dir);
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(json::parse(readFile(stats_path))["realtime"], true);
    EXPECT_NE(r.err.find("SCHED_FIFO priority 80"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("NOT REAL-TIME"), std::string::npos);
}

TEST(IrpdRun, StatsAreReadableLiveFromAnotherProcess) {
    TempDir dir;
    const std::string instance = uniqueInstance();
    Process p({kIrpd, "--config", kFig1, "--instance", instance}, dir.path);
    ASSERT_TRUE(p.waitForErr("irpd: running")) << p.err();
    auto shm = irp::osal::SharedMemory::open("/indurop." + instance + ".stats", false);
    ASSERT_TRUE(shm.ok()) << shm.error().message;
    const auto *h = static_cast<const irp::stats::Header *>(shm->data());
    ASSERT_EQ(h->magic, irp::stats::kMagic);
    ASSERT_EQ(h->version, irp::stats::kVersion);
    ASSERT_EQ(h->record_size, sizeof(irp::stats::TimingRecord));
    EXPECT_EQ(h->pid, p.pid());
    EXPECT_EQ(h->basic_ns, 100000);
    EXPECT_GE(h->record_count, 1u + 7u);  // the main dispatcher + the 7 modules of Figure 1 (+ room for hot reloads)
    const irp::stats::TimingRecord *r = irp::stats::records(h);
    EXPECT_STREQ(r[0].name, "dispatcher");
    EXPECT_STREQ(r[1].name, "cntr1");
    EXPECT_EQ(r[1].state.load(), static_cast<uint32_t>(irp::stats::ModuleState::Running));
    EXPECT_EQ(r[4].state.load(), static_cast<uint32_t>(irp::stats::ModuleState::Running));  // cntr4, a process
    const uint64_t before = h->cycles.load();
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    const uint64_t after = h->cycles.load();
    EXPECT_GT(after, before + 100);                         // the RT thread keeps going while it is being read
    EXPECT_GT(irp::stats::summarize(r[3].exec).count, 0u);  // cntr3's histogram, read live
    kill(p.pid(), SIGTERM);
    EXPECT_EQ(p.wait(std::chrono::seconds(10)), 0);
}

TEST(IrpdOptions, PrintShmLayoutDescribesEverySegment) {
    TempDir dir;
    Outcome r = irpd({"--print-shm-layout"}, dir);
    ASSERT_EQ(r.status, 0) << r.err;
    json j = json::parse(r.out);
    EXPECT_EQ(j["format"], irp::shm::kDescriptionFormat);
    EXPECT_EQ(j["segments"]["stats"]["magic"].get<uint64_t>(), irp::stats::kMagic);
    EXPECT_EQ(j["segments"]["stats"]["structs"]["stats_header"]["size"], sizeof(irp::stats::Header));
    EXPECT_EQ(j["segments"]["stats"]["structs"]["stats_header"]["fields"]["cycles"]["offset"],
              offsetof(irp::stats::Header, cycles));
    EXPECT_EQ(j["segments"]["stats"]["structs"]["timing_record"]["fields"]["latency"]["offset"],
              offsetof(irp::stats::TimingRecord, latency));
    EXPECT_EQ(j["segments"]["stats"]["structs"]["histogram"]["fields"]["buckets"]["count"], irp::stats::kBuckets);
    for (const char *segment : {"variables", "stats", "trace", "control"}) EXPECT_TRUE(j["segments"].contains(segment));
}

TEST(IrpdRefuses, AModuleBuiltAgainstAnotherLayoutWithBothHashes) {
    TempDir dir;
    copyFig1Module("cntr1.so", dir);
    // The same layout under another hash stands for a .glb that changed since cntr1 was built.
    std::string layout = readFile(dir.path / "layout.json");
    const std::string built = json::parse(layout)["hash"];
    const std::string other(64, 'a');
    layout.replace(layout.find(built), built.size(), other);
    writeFile(dir.path / "layout.json", layout);
    writeFile(dir.path / "module.xml", "<root>\n" + module("./cntr1.so", 100000, 1) + "</root>\n");
    Outcome r = irpd({"--config", (dir.path / "module.xml").string()}, dir);
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("module 'cntr1': "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("built against shared-variable layout " + built), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("which is neither the layout " + other), std::string::npos) << r.err;
    EXPECT_EQ(r.out.find("[cntr1] initialize"), std::string::npos);
}

TEST(IrpdRefuses, AModuleUsingVariablesInASetWithoutLayout) {
    TempDir dir;
    std::filesystem::copy_file(std::string(BUILD_ROOT) + "/sets/paper-fig1/cntr1.so", dir.path / "cntr1.so");
    writeFile(dir.path / "module.xml", "<root>\n" + module("./cntr1.so", 100000, 1) + "</root>\n");
    Outcome r = irpd({"--config", (dir.path / "module.xml").string()}, dir);
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("uses shared variables (layout "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("but the set declares no <layout>"), std::string::npos) << r.err;
}

TEST(IrpdRefuses, AMalformedLayout) {
    TempDir dir;
    writeFile(dir.path / "layout.json", "{\"format\": \"indurop-layout\", \"version\": 7}");
    writeFile(dir.path / "module.xml",
              "<root>\n" + module(std::string(FIXTURE_MODULES) + "/rec_a.so", 100000, 1) + "</root>\n");
    Outcome r = irpd({"--config", (dir.path / "module.xml").string()}, dir);
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("layout.json: layout version 7; this irpd reads version 1"), std::string::npos) << r.err;
}

// Variables share a lock only as the members of one lock group (glbc's lock_group: an ST PROGRAM
// instance's structs and arrays); a shared lock outside a group is a malformed layout.
TEST(IrpdLayout, VariablesShareALockOnlyWithinALockGroup) {
    json layout = json::parse(readFile(std::string(BUILD_ROOT) + "/sets/paper-fig1/layout.json"));
    ASSERT_GE(layout["variables"].size(), 2u);
    layout["variables"][1]["lock"] = layout["variables"][0]["lock"];
    for (const bool grouped : {false, true}) {
        TempDir dir;
        if (grouped)
            for (int i : {0, 1}) layout["variables"][i]["lock_group"] = "g";
        writeFile(dir.path / "layout.json", layout.dump());
        writeFile(dir.path / "module.xml",
                  "<root>\n" + module(std::string(FIXTURE_MODULES) + "/rec_a.so", 100000, 1) + "</root>\n");
        Outcome r = irpd(
            {"--config", (dir.path / "module.xml").string(), "--duration", "0.2", "--instance", uniqueInstance()}, dir);
        const std::string path = layout["variables"][1]["path"];
        if (grouped) {
            EXPECT_EQ(r.status, 0) << r.err;
        } else {
            EXPECT_EQ(r.status, 2);
            EXPECT_NE(r.err.find("variable " + path + " shares lock"), std::string::npos) << r.err;
            EXPECT_NE(r.err.find("outside its lock group"), std::string::npos) << r.err;
        }
    }
}

TEST(IrpdRun, ThePapersFigures4578RunAsOneSet) {
    TempDir dir;
    const auto stats_path = dir.path / "stats.json";
    Outcome r = irpd({"--config", std::string(BUILD_ROOT) + "/sets/paper-figures/module.xml", "--duration", "1.1",
                      "--stats-json", stats_path.string(), "--instance", uniqueInstance()},
                     dir);
    ASSERT_EQ(r.status, 0) << r.err;
    json s = json::parse(readFile(stats_path));
    std::map<std::string, json> by_name;
    for (const json &m : s["modules"]) by_name[m["name"]] = m;
    // Figure 4 prints joints[0], which Figure 5 advances by tick: x, y and z stay equal.
    const std::regex line(R"(joints\[0\] = \{([0-9.]+), ([0-9.]+), ([0-9.]+)\})");
    int lines = 0;
    for (auto it = std::sregex_iterator(r.out.begin(), r.out.end(), line); it != std::sregex_iterator(); ++it, ++lines)
        EXPECT_TRUE((*it)[1] == (*it)[2] && (*it)[2] == (*it)[3]) << it->str();
    EXPECT_EQ(lines, by_name.at("output")["runs"].get<int>());
    EXPECT_EQ(by_name.at("modify")["runs"].get<uint64_t>() + by_name.at("modify")["skipped"].get<uint64_t>(), 1100u);
    // Figure 7 fires each time the driver has turned joint[0].x to 180 (1 degree a period).
    if (by_name.at("driver")["skipped"] == 0) {
        EXPECT_EQ(by_name.at("sporadic_thread")["runs"], 6);
    }
    // Figure 8, a sporadic process, was released and completed basic periods, and saw its event.
    EXPECT_GT(by_name.at("sporadic_process")["runs"].get<uint64_t>(), 0u);
    EXPECT_NE(r.out.find("[sporadic_process] Figure 8: event 1, joint[1].y = 180.0"), std::string::npos) << r.out;
}
