// test_online_change.cpp -- a changed shared-variable layout swapped in while irpd runs, through
// its control socket (docs/hot-reload.md, docs/shared-variables.md "Layouts that evolve"): a kept
// counter module misses no period and its variable keeps counting while a variable is added,
// one removed and one retyped; a process built against the old layout is accepted; a module
// built against an incompatible layout (refused by the dry run `check` as by the load), a layout
// laid out afresh and one over the room are refused with what to change, and the running set is
// left as it was; a process that fits no layout of a set needing a restart is refused by the dry
// run and the restart rather than offered one; the dry run names the modules a load keeps,
// starts, stops and replaces.  Executors added, removed
// and changed at a swap: their threads start before it and stop after it, the counter on main
// missing no period.  Retyped variables converted at the swap; a narrowed one named by the dry run,
// which offers only the managed restart (the load is refused as restart_required).
#include "support/online_cell.hpp"

#include <indurop/process.h>
#include <indurop/shared.h>

#include <gtest/gtest.h>

#include <signal.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <regex>
#include <thread>

using namespace online_cell;  // Cell, thread(), process(), and the names it uses (json, fs, TempDir ...)

TEST(OnlineChange, AVariableIsAddedWhileTheCounterKeepsCounting) {
    Cell cell;
    settle();
    const uint64_t before = cell.u64("oc.counter");
    EXPECT_GT(before, 0u);
    // The counter module rebuilt against v2 is the same code: kept.  The adder is new.
    json answer = cell.load(cell.writeSet("v2.xml", "v2",
                                          thread("counter", "oc_counter_v2.so", cell.dir.path) +
                                              thread("adder", "oc_adder_v2.so", cell.dir.path, 2)));
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    const json &report = answer["result"];
    EXPECT_EQ(report["kept"], json({"counter"}));
    EXPECT_EQ(report["started"], json({"adder"}));
    EXPECT_EQ(report["variables"]["added"], json({"oc.added"}));
    EXPECT_EQ(report["variables"]["removed"], json::array());
    EXPECT_TRUE(report["missed_periods"].is_number_unsigned()) << "reported; a timing figure, not asserted";
    settle();
    const uint64_t after = cell.u64("oc.counter");
    EXPECT_GT(after, before) << "the counter's value was kept and it went on counting";
    const double added = cell.f64("oc.added");
    EXPECT_GT(added, static_cast<double>(before)) << "the new variable is written by the new module";
    cell.expectCounterMissedNoPeriod();
}

TEST(OnlineChange, AVariableIsRemovedAndItsRoomStaysAHole) {
    Cell cell;
    ASSERT_TRUE(cell.load(cell.writeSet("v2.xml", "v2", thread("counter", "oc_counter_v1.so", cell.dir.path)))["ok"]);
    // v1's counter module still uses the v1 layout, which had `gone`: accepted, `gone` is a hole.
    json answer = cell.load(cell.writeSet("v3.xml", "v3", thread("counter", "oc_counter_v1.so", cell.dir.path)));
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    EXPECT_EQ(answer["result"]["kept"], json({"counter"}));
    EXPECT_EQ(answer["result"]["variables"]["removed"], json({"oc.gone"}));
    int32_t gone = 0;
    EXPECT_EQ(read(cell.vars, "oc.gone", sizeof gone, &gone), -1) << "a removed variable has no path";
    settle();
    cell.expectCounterMissedNoPeriod();
}

// v4 narrows oc.retyped (double -> float): its users must be rebuilt, and even then only a managed
// restart runs the set (its value cannot be converted without loss).
TEST(OnlineChange, ARetypedVariableThatLosesValuesNeedsARestartAndItsUsersARebuild) {
    Cell cell;
    ASSERT_TRUE(cell.load(cell.writeSet("v3.xml", "v3",
                                        thread("counter", "oc_counter_v1.so", cell.dir.path) +
                                            thread("retyped", "oc_retyped_v3.so", cell.dir.path, 2)))["ok"]);
    settle();
    EXPECT_GT(cell.f64("oc.retyped"), 0.0);
    const json generation = cell.generation();
    // v4 makes oc.retyped a float: the module built against v3 has no place in it.
    json refused = cell.load(cell.writeSet("v4-old.xml", "v4",
                                           thread("counter", "oc_counter_v1.so", cell.dir.path) +
                                               thread("retyped", "oc_retyped_v3.so", cell.dir.path, 2)));
    ASSERT_FALSE(refused.value("ok", true)) << refused.dump();
    const std::string message = refused["error"]["message"];
    EXPECT_NE(message.find("'oc.retyped'"), std::string::npos) << message;
    EXPECT_NE(message.find("rebuild it against the set's .glb files"), std::string::npos) << message;
    EXPECT_EQ(cell.generation(), generation) << "the running set is left as it was";
    double still = 0;
    EXPECT_EQ(read(cell.vars, "oc.retyped", sizeof still, &still), static_cast<int>(sizeof still))
        << "the old layout is published again: oc.retyped is the double it was";

    // Rebuilt against v4, the modules fit it; still oc.retyped cannot be converted without loss, so
    // the load is refused as restart_required, naming it with its types, and the set runs on.
    const std::string v4 = cell.writeSet("v4.xml", "v4",
                                         thread("counter", "oc_counter_v4.so", cell.dir.path) +
                                             thread("retyped", "oc_retyped_v4.so", cell.dir.path, 2));
    const json check = cell.ask({{"cmd", "check"}, {"config", v4}})["result"];
    EXPECT_TRUE(check["valid"].get<bool>()) << check.dump();
    EXPECT_FALSE(check["online"].get<bool>()) << check.dump();
    ASSERT_EQ(check["variables"]["moved"].size(), 1u) << check.dump();
    EXPECT_EQ(check["variables"]["moved"][0]["path"], "oc.retyped");
    EXPECT_EQ(check["variables"]["moved"][0]["from_type"], "double");
    EXPECT_EQ(check["variables"]["moved"][0]["to_type"], "float");
    const std::string reason = check["restart"]["reason"];
    EXPECT_NE(reason.find("'oc.retyped' double -> float"), std::string::npos) << reason;
    EXPECT_NE(reason.find("managed restart"), std::string::npos) << reason;
    json answer = cell.load(v4);
    ASSERT_FALSE(answer.value("ok", true)) << answer.dump();
    EXPECT_EQ(answer["error"]["code"], "restart_required") << answer.dump();
    EXPECT_EQ(answer["error"]["message"], reason);
    EXPECT_EQ(cell.generation(), generation) << "the running set is left as it was";
    const double before = cell.f64("oc.retyped");
    settle();
    EXPECT_GT(cell.f64("oc.retyped"), before) << "the running module counts on in the double";
    cell.expectCounterMissedNoPeriod();
}

namespace {

// After cv1 -> cv2 with the cv module counting: every variable as cv2.glb says it was converted.
void expectConvertedByCv2(Cell &cell, int32_t count_before) {
    // The count went on from where it was (zeroed, it would be the few periods since the swap), and
    // the new module's first run already read the converted values.
    const int32_t count_after = cell.value<int32_t>("cv.fb.count");
    EXPECT_GT(count_after, count_before);
    EXPECT_GE(cell.value<int32_t>("cv.first_count"), count_before) << "the new module's first run saw the count";
    settle();
    EXPECT_GT(cell.value<int32_t>("cv.fb.count"), count_after) << "the new module counts on";
    EXPECT_EQ(cell.value<int16_t>("cv.fb.mode"), 5);
    EXPECT_EQ(cell.value<double>("cv.fb.added"), 0.0) << "a new field starts at zero";
    EXPECT_EQ(cell.value<int32_t>("cv.wide"), -1234);
    for (int i = 0; i < 5; ++i) {
        const std::string path = "cv.arr[" + std::to_string(i) + "]";
        EXPECT_EQ(cell.value<int32_t>(path.c_str()), i < 3 ? 10 * (i + 1) : 0) << path;
    }
    EXPECT_EQ(cell.value<int32_t>("cv.narrow"), 70000) << "kept";
    EXPECT_EQ(cell.value<double>("cv.f"), 1.5);
    EXPECT_EQ(cell.value<float>("cv.i2f"), -300.0f);
    EXPECT_EQ(cell.value<int32_t>("cv.nest[0].inner.a"), -7);
    EXPECT_EQ(cell.value<double>("cv.nest[0].inner.b"), 2.25);
    EXPECT_EQ(cell.value<uint8_t>("cv.nest[0].tag"), 9);
    EXPECT_EQ(cell.value<int32_t>("cv.nest[1].inner.a"), 32000);
    EXPECT_EQ(cell.value<double>("cv.nest[1].inner.b"), -0.5);
    EXPECT_EQ(cell.value<uint8_t>("cv.nest[1].tag"), 200);
    EXPECT_EQ(cell.value<int8_t>("cv.nest[1].inner.c"), 0) << "a new field starts at zero";
    EXPECT_EQ(cell.value<int32_t>("cv.nest[2].inner.a"), 0) << "a new element starts at zero";
    EXPECT_EQ(cell.value<uint8_t>("cv.nest[2].tag"), 0);
    EXPECT_EQ(cell.value<int32_t>("cv.wrong"), 0) << "the new module never read a value before it was converted";
}

}  // namespace

// Retyped variables keep their values where no value can be lost (docs/hot-reload.md "Converted
// variables"): cv1 -> cv2 while a module counts in a field of a struct that gains a field.
TEST(OnlineChange, RetypedVariablesAreConvertedAtTheSwap) {
    Cell cell("", {}, "cv1", {"cv", "oc_cv_v1.so"});
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    // Before: what the v1 module wrote, in cv1's types.
    EXPECT_EQ(cell.value<int16_t>("cv.wide"), -1234);
    EXPECT_EQ(cell.value<int32_t>("cv.narrow"), 70000);
    EXPECT_EQ(cell.value<float>("cv.f"), 1.5f);
    EXPECT_EQ(cell.value<int16_t>("cv.nest[1].inner.a"), 32000);
    const std::string xml = cell.writeSet("cv2.xml", "cv2", thread("cv", "oc_cv_v2.so", cell.dir.path));

    // The dry run names what it converts, and the variable it cannot, with why and what it means.
    json check = cell.ask({{"cmd", "check"}, {"config", xml}})["result"];
    EXPECT_TRUE(check["online"].get<bool>()) << check.dump();
    std::map<std::string, std::pair<std::string, std::string>> converted;
    for (const json &c : check["variables"]["converted"]) converted[c["path"]] = {c["from_type"], c["to_type"]};
    using Types = std::pair<std::string, std::string>;
    EXPECT_EQ(converted.size(), 6u) << check.dump();
    EXPECT_EQ(converted["cv.wide"], Types("int16_t", "int32_t"));
    EXPECT_EQ(converted["cv.arr"], Types("int32_t[3]", "int32_t[5]"));
    EXPECT_EQ(converted["cv.f"], Types("float", "double"));
    EXPECT_EQ(converted["cv.i2f"], Types("int16_t", "float"));
    EXPECT_EQ(converted["cv.fb"], Types("cv.fb_t", "cv.fb_t"));
    EXPECT_EQ(converted["cv.nest"], Types("cv.nest_t[2]", "cv.nest_t[3]"));
    EXPECT_EQ(check["variables"]["moved"], json::array()) << check.dump();

    const int32_t count_before = cell.value<int32_t>("cv.fb.count");
    EXPECT_GT(count_before, 300);
    json answer = cell.load(xml);
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    EXPECT_EQ(answer["result"]["variables"]["converted"], check["variables"]["converted"]);
    EXPECT_EQ(answer["result"]["variables"]["moved"], json::array());
    expectConvertedByCv2(cell, count_before);
}

// A retyped variable whose value cannot be converted without loss (int32 -> int16): the dry run
// names it with its types and why, and offers only the managed restart; the load is refused as
// restart_required with the same reason, and the running set counts on with its values.
TEST(OnlineChange, ANarrowedVariableIsNamedAndOnlyARestartRunsIt) {
    Cell cell("", {}, "cv1", {"cv", "oc_cv_v1.so"});
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    const std::string xml =
        cell.writeSet("cv-narrow.xml", "cv_narrow", thread("cv", "oc_cv_v_narrow.so", cell.dir.path));
    json check = cell.ask({{"cmd", "check"}, {"config", xml}})["result"];
    EXPECT_TRUE(check["valid"].get<bool>()) << check.dump();
    EXPECT_FALSE(check["online"].get<bool>()) << check.dump();
    ASSERT_EQ(check["variables"]["moved"].size(), 1u) << check.dump();
    const json &moved = check["variables"]["moved"][0];
    EXPECT_EQ(moved["path"], "cv.narrow");
    EXPECT_EQ(moved["from_type"], "int32_t");
    EXPECT_EQ(moved["to_type"], "int16_t");
    EXPECT_EQ(moved["reason"], "cv.narrow: int32_t to int16_t may lose values");
    const std::string reason = check["restart"]["reason"];
    EXPECT_NE(reason.find("'cv.narrow' int32_t -> int16_t (cv.narrow: int32_t to int16_t may lose values)"),
              std::string::npos)
        << reason;
    EXPECT_NE(reason.find("only the managed restart (activate --mode restart or auto)"), std::string::npos) << reason;
    EXPECT_TRUE(check["restart"].contains("expected_downtime_ns")) << check.dump();

    const json generation = cell.generation();
    const int32_t count_before = cell.value<int32_t>("cv.fb.count");
    json answer = cell.load(xml);
    ASSERT_FALSE(answer.value("ok", true)) << answer.dump();
    EXPECT_EQ(answer["error"]["code"], "restart_required");
    EXPECT_EQ(answer["error"]["message"], reason);
    EXPECT_EQ(cell.generation(), generation) << "the running set is left as it was";
    EXPECT_EQ(cell.value<int32_t>("cv.narrow"), 70000);
    settle();
    EXPECT_GT(cell.value<int32_t>("cv.fb.count"), count_before) << "the running module counts on";
}

// A conversion plan that copies outside its variable (a layout.json edited by hand) is refused by
// the dry run and the load alike, naming the variable; the running set is left as it was.
TEST(OnlineChange, AConversionOutsideItsVariableIsRefused) {
    Cell cell("", {}, "cv1", {"cv", "oc_cv_v1.so"});
    json layout = json::parse(readFile(layoutOf("cv2")));
    for (json &c : layout["changes"]["converted"])
        if (c["path"] == "cv.wide") c["copies"][0]["to"] = c["copies"][0]["to"].get<uint64_t>() + 64;
    std::ofstream(cell.dir.path / "tampered.json") << layout.dump();
    std::ofstream(cell.dir.path / "tampered.xml")
        << "<root>\n  <layout>" << (cell.dir.path / "tampered.json").string() << "</layout>\n"
        << thread("cv", "oc_cv_v2.so", cell.dir.path) << "</root>\n";
    const std::string xml = (cell.dir.path / "tampered.xml").string();
    const json generation = cell.generation();
    json check = cell.ask({{"cmd", "check"}, {"config", xml}})["result"];
    EXPECT_FALSE(check["valid"].get<bool>()) << check.dump();
    const std::string expected =
        "the conversion of variable 'cv.wide' copies bytes outside the variable (or overlapping scalars): compile the "
        "set's .glb files again with glbc --previous";
    EXPECT_NE(check["errors"].dump().find(expected), std::string::npos) << check.dump();
    json refused = cell.load(xml);
    ASSERT_FALSE(refused.value("ok", true)) << refused.dump();
    EXPECT_NE(refused["error"]["message"].get<std::string>().find(expected), std::string::npos) << refused.dump();
    EXPECT_EQ(cell.generation(), generation);
    EXPECT_EQ(cell.value<int16_t>("cv.wide"), -1234) << "the running layout and its values are untouched";

    // A count of scalars larger than the variable (stride 0): refused too, not looped over at the swap.
    for (json &c : layout["changes"]["converted"])
        if (c["path"] == "cv.wide") {
            c["copies"][0]["to"] = c["to"];
            c["copies"][0]["count"] = uint64_t{1} << 40;
        }
    std::ofstream(cell.dir.path / "tampered.json") << layout.dump();
    check = cell.ask({{"cmd", "check"}, {"config", xml}})["result"];
    EXPECT_NE(check["errors"].dump().find(expected), std::string::npos) << check.dump();
}

TEST(OnlineChange, AProcessBuiltAgainstTheOldLayoutRunsOnTheNewOne) {
    Cell cell;
    json answer = cell.load(cell.writeSet(
        "v2.xml", "v2", thread("counter", "oc_counter_v1.so", cell.dir.path) + process("proc", "oc_proc_v1.exe")));
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump() << cell.irpd->err();
    EXPECT_EQ(answer["result"]["started"], json({"proc"}));
    settle();
    EXPECT_GT(cell.u64("oc.proc_runs"), 0u) << cell.irpd->err();
    cell.expectCounterMissedNoPeriod();
}

TEST(OnlineChange, ALayoutNotLaidOutAgainstTheRunningOneNeedsARestart) {
    Cell cell;
    const json generation = cell.generation();
    const std::string xml =
        cell.writeSet("reordered.xml", "reordered", thread("counter", "oc_counter_reordered.so", cell.dir.path));
    json check = cell.ask({{"cmd", "check"}, {"config", xml}});
    ASSERT_TRUE(check.value("ok", false)) << check.dump();
    EXPECT_EQ(check["result"]["valid"], true);
    EXPECT_EQ(check["result"]["online"], false);
    const std::string reason = check["result"]["restart"]["reason"];
    EXPECT_NE(reason.find("keeps its type but moves"), std::string::npos) << check.dump();
    EXPECT_NE(reason.find("glbc --previous"), std::string::npos) << reason;
    json refused = cell.load(xml);
    ASSERT_FALSE(refused.value("ok", true));
    EXPECT_EQ(refused["error"]["code"], "restart_required") << refused.dump();
    EXPECT_EQ(cell.generation(), generation);
    settle();
    cell.expectCounterMissedNoPeriod();
}

TEST(OnlineChange, ANewModuleBuiltAgainstALayoutTheSetsWasNotLaidOutFromIsRefusedByTheDryRunAsByTheLoad) {
    Cell cell;
    const json generation = cell.generation();
    // v3's layout.json was laid out against v2 and v1 (glbc --previous); the new adder was built
    // against v3.glb compiled without --previous: another stamp, in no layout of v3's lineage.
    const std::string xml = cell.writeSet("afresh.xml", "v3",
                                          thread("counter", "oc_counter_v1.so", cell.dir.path) +
                                              thread("adder", "oc_adder_v3_afresh.so", cell.dir.path, 2));
    json check = cell.ask({{"cmd", "check"}, {"config", xml}});
    ASSERT_TRUE(check.value("ok", false)) << check.dump();
    const json &found = check["result"];
    EXPECT_EQ(found["valid"], false) << found.dump();
    EXPECT_EQ(found["online"], false) << found.dump();
    EXPECT_TRUE(found["restart"].is_null()) << "a restart would refuse it too: " << found.dump();
    ASSERT_EQ(found["errors"].size(), 1u) << found.dump();
    const std::string said = found["errors"][0];
    EXPECT_NE(said.find("module 'adder'"), std::string::npos) << said;
    EXPECT_NE(said.find("rebuild it against the set's .glb files"), std::string::npos) << said;
    EXPECT_EQ(found["problems"][0]["module"], "adder") << found.dump();
    EXPECT_EQ(found["problems"][0]["file"], (kOnline / "modules" / "oc_adder_v3_afresh.so").string());

    json refused = cell.load(xml);
    ASSERT_FALSE(refused.value("ok", true)) << refused.dump();
    EXPECT_EQ(refused["error"]["code"], "refused") << refused.dump();
    EXPECT_EQ(refused["error"]["message"], said) << "the dry run says what the load says";
    EXPECT_EQ(cell.generation(), generation) << "the running set is left as it was";
    settle();
    cell.expectCounterMissedNoPeriod();
}

TEST(OnlineChange, AProcessThatFitsNoLayoutOfTheSetIsRefusedRatherThanOfferedARestart) {
    Cell cell;
    // `reordered` needs a restart, but the process was built against v1, which is not in its
    // lineage: a restart onto it would fail too, so the dry run refuses it, naming the process.
    const std::string xml =
        cell.writeSet("reordered-proc.xml", "reordered",
                      thread("counter", "oc_counter_reordered.so", cell.dir.path) + process("proc", "oc_proc_v1.exe"));
    json check = cell.ask({{"cmd", "check"}, {"config", xml}});
    ASSERT_TRUE(check.value("ok", false)) << check.dump();
    EXPECT_EQ(check["result"]["valid"], false) << check.dump();
    EXPECT_TRUE(check["result"]["restart"].is_null()) << check.dump();
    EXPECT_EQ(check["result"]["problems"][0]["module"], "proc") << check.dump();
    json refused = cell.ask({{"cmd", "restart"}, {"config", xml}});
    ASSERT_FALSE(refused.value("ok", true)) << refused.dump();
    EXPECT_EQ(refused["error"]["message"], check["result"]["errors"][0]) << "nothing restarted: " << refused.dump();
    settle();
    cell.expectCounterMissedNoPeriod();
}

TEST(OnlineChange, TheDryRunNamesTheModulesALoadKeepsStartsStopsAndReplaces) {
    Cell cell;
    ASSERT_TRUE(cell.load(cell.writeSet("v2.xml", "v2",
                                        thread("counter", "oc_counter_v2.so", cell.dir.path) +
                                            thread("adder", "oc_adder_v2.so", cell.dir.path, 2) +
                                            thread("adder2", "oc_adder_v2.so", cell.dir.path, 3)))["ok"]);
    // counter the same; adder other code under its name; adder2 gone; fresh new.
    const std::string xml = cell.writeSet("next.xml", "v2",
                                          thread("counter", "oc_counter_v2.so", cell.dir.path) +
                                              thread("adder", "oc_counter_v2.so", cell.dir.path, 2) +
                                              thread("fresh", "oc_adder_v2.so", cell.dir.path, 3));
    json check = cell.ask({{"cmd", "check"}, {"config", xml}});
    ASSERT_TRUE(check.value("ok", false)) << check.dump();
    const json &modules = check["result"]["modules"];
    EXPECT_EQ(modules["kept"], json({"counter"})) << modules.dump();
    EXPECT_EQ(modules["started"], json({"adder", "fresh"})) << modules.dump();
    EXPECT_EQ(modules["stopped"], json({"adder", "adder2"})) << modules.dump();
    EXPECT_EQ(modules["replaced"], json({"adder"})) << modules.dump();
    json answer = cell.load(xml);
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    for (const char *fate : {"kept", "started", "stopped", "replaced"})
        EXPECT_EQ(answer["result"][fate], modules[fate]) << fate << ": the load does what the dry run said";
    cell.expectCounterMissedNoPeriod();
}

TEST(OnlineChange, ALayoutOverTheRoomNamesTheOptionThatMakesMore) {
    Cell cell;
    json refused = cell.load(cell.writeSet("big.xml", "big", thread("counter", "oc_counter_v1.so", cell.dir.path)));
    ASSERT_FALSE(refused.value("ok", true));
    EXPECT_EQ(refused["error"]["code"], "restart_required") << refused.dump();
    const std::string message = refused["error"]["message"];
    EXPECT_NE(message.find("--var-headroom"), std::string::npos) << message;
    cell.expectCounterMissedNoPeriod();
}

TEST(OnlineChange, MoreRoomTakesTheBigLayoutOnline) {
    Cell cell("", {"--var-headroom", "8M"});
    json answer = cell.load(cell.writeSet("big.xml", "big", thread("counter", "oc_counter_v1.so", cell.dir.path)));
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    EXPECT_EQ(answer["result"]["variables"]["added"], json({"oc.huge"}));
    cell.expectCounterMissedNoPeriod();
}

TEST(OnlineChange, TheFixedRoomIsNamedWithTheOptionThatRaisesIt) {
    Cell cell("", {"--module-records", "1", "--process-slots", "1"});
    // One module record, taken by the counter: a new module has none left.
    json refused = cell.load(cell.writeSet("v2.xml", "v2",
                                           thread("counter", "oc_counter_v2.so", cell.dir.path) +
                                               thread("adder", "oc_adder_v2.so", cell.dir.path, 2)));
    ASSERT_FALSE(refused.value("ok", true));
    EXPECT_EQ(refused["error"]["code"], "restart_required") << refused.dump();
    EXPECT_NE(refused["error"]["message"].get<std::string>().find("--module-records"), std::string::npos)
        << refused.dump();
    // One process slot: a set with two processes cannot be taken online.
    refused = cell.load(cell.writeSet("procs.xml", "v1",
                                      thread("counter", "oc_counter_v1.so", cell.dir.path) +
                                          process("p1", "oc_proc_v1.exe") + process("p2", "oc_proc_v1.exe")));
    ASSERT_FALSE(refused.value("ok", true));
    EXPECT_EQ(refused["error"]["code"], "restart_required") << refused.dump();
    EXPECT_NE(refused["error"]["message"].get<std::string>().find("--process-slots"), std::string::npos)
        << refused.dump();
    cell.expectCounterMissedNoPeriod();
}

// ---- exporters of shared functions replaced online -----------------------------------------------

namespace {

std::string fixture(const std::string &name, const std::string &file, int64_t period_ns, int priority,
                    const std::string &type = "thread", const std::string &extra = "") {
    return "  <module><name>" + name + "</name><filename>" + std::string(FIXTURE_MODULES) + "/../" +
           (type == "thread" ? "modules/" : "processes/bin/") + file + "</filename><moduletype>" + type +
           "</moduletype><operationtype>" + (period_ns ? "periodic" : "non-real") + "</operationtype>" +
           (period_ns ? "<period>" + std::to_string(period_ns) + "</period><priority>" + std::to_string(priority) +
                            "</priority>"
                      : "") +
           extra + "</module>\n";
}

}  // namespace

TEST(OnlineChange, AnExporterAKeptModuleCallsIntoNeedsThatModuleReplacedToo) {
    Cell cell(fixture("math", "fn_export.so", 1'000'000, 2) + fixture("user", "fn_import.so", 1'000'000, 3));
    const json generation = cell.generation();
    json refused = cell.load(cell.writeSet("v1-math2.xml", "v1",
                                           thread("counter", "oc_counter_v1.so", cell.dir.path) +
                                               fixture("math", "fn_export_v2.so", 1'000'000, 2) +
                                               fixture("user", "fn_import.so", 1'000'000, 3)));
    ASSERT_FALSE(refused.value("ok", true));
    EXPECT_EQ(refused["error"]["code"], "restart_required") << refused.dump();
    const std::string message = refused["error"]["message"];
    EXPECT_NE(message.find("module 'user' keeps running and calls shared functions of module 'math' (math.scale)"),
              std::string::npos)
        << message;
    EXPECT_EQ(cell.generation(), generation);
    // With its user replaced too, the new exporter goes in online; so does removing both.
    json answer = cell.load(cell.writeSet("v1-both.xml", "v1",
                                          thread("counter", "oc_counter_v1.so", cell.dir.path) +
                                              fixture("math", "fn_export_v2.so", 1'000'000, 2) +
                                              fixture("user", "fn_import_v2.so", 1'000'000, 3)));
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    EXPECT_EQ(answer["result"]["started"], json({"math", "user"}));
    answer = cell.load(cell.writeSet("v1-none.xml", "v1", thread("counter", "oc_counter_v1.so", cell.dir.path)));
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    EXPECT_EQ(answer["result"]["stopped"], json({"math", "user"}));
    cell.expectCounterMissedNoPeriod();
}

TEST(OnlineChange, ProcessesCallTheNewCodeOfAnExporterReplacedOnline) {
    Cell cell(fixture("owner", "fn_owner.so", 1'000'000, 2) +
              fixture("caller", "fn_caller.exe", 0, 0, "process",
                      "<property><value name=\"args\">--loop</value></property>"));
    ASSERT_TRUE(cell.irpd->waitForOut("scale=10")) << cell.irpd->out() << cell.irpd->err();
    json answer = cell.load(cell.writeSet("owner2.xml", "v1",
                                          thread("counter", "oc_counter_v1.so", cell.dir.path) +
                                              fixture("owner", "fn_owner_v2.so", 1'000'000, 2) +
                                              fixture("caller", "fn_caller.exe", 0, 0, "process",
                                                      "<property><value name=\"args\">--loop</value></property>")));
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    EXPECT_EQ(answer["result"]["started"], json({"owner"}));
    EXPECT_EQ(answer["result"]["kept"], json({"counter", "caller"}));
    EXPECT_TRUE(cell.irpd->waitForOut("scale=14")) << cell.irpd->out() << cell.irpd->err();
    EXPECT_EQ(cell.irpd->out().find("scale failed"), std::string::npos) << cell.irpd->out();
    cell.expectCounterMissedNoPeriod();
}

// ---- executors added, removed and changed online -------------------------------------------------

namespace {

// An <executor> of the set's root.
std::string executor(const std::string &name, int rt_priority = 0, int cpu = -1) {
    return "  <executor><name>" + name + "</name>" +
           (rt_priority ? "<rtpriority>" + std::to_string(rt_priority) + "</rtpriority>" : "") +
           (cpu >= 0 ? "<cpu>" + std::to_string(cpu) + "</cpu>" : "") + "</executor>\n";
}

// irpd's executor threads ("irp@<name>", /proc/<pid>/task/*/comm) and the RT priority of each.
std::map<std::string, int> executorThreads(pid_t pid) {
    std::map<std::string, int> threads;
    for (const auto &task : fs::directory_iterator("/proc/" + std::to_string(pid) + "/task")) {
        std::string comm = readFile(task.path() / "comm");
        if (!comm.empty() && comm.back() == '\n') comm.pop_back();
        if (comm.rfind("irp@", 0) != 0) continue;
        // field 40 of stat is rt_priority; the name in field 2 may hold spaces, so count after ')'
        std::istringstream stat(readFile(task.path() / "stat").substr(readFile(task.path() / "stat").rfind(')') + 2));
        std::string field;
        for (int i = 3; i <= 40 && stat >> field; ++i) {}
        threads[comm.substr(4)] = std::stoi(field);
    }
    return threads;
}

// The kernel id of irpd's thread for executor `name` ("irp@<name>"), or 0 when there is none.
pid_t executorTid(pid_t pid, const std::string &name) {
    for (const auto &task : fs::directory_iterator("/proc/" + std::to_string(pid) + "/task"))
        if (readFile(task.path() / "comm") == "irp@" + name + "\n") return std::stoi(task.path().filename());
    return 0;
}

// The stats of the running generation's dispatchers, by executor name.
std::map<std::string, json> dispatchers(Cell &cell) {
    std::map<std::string, json> by_name;
    const json stats = cell.ask({{"cmd", "stats"}});
    for (const json &d : stats["result"]["executors"]) by_name[d["executor"].get<std::string>()] = d;
    return by_name;
}

json moduleStats(Cell &cell, const std::string &name) {
    const json stats = cell.ask({{"cmd", "stats"}});
    for (const json &m : stats["result"]["modules"])
        if (m["name"] == name) return m;
    return nullptr;
}

// The v2 set: counter on main (kept from v1), adder on executor `side` (its priority and CPU, and
// the adder's period, which is side's basic period).
std::string withSide(Cell &cell, int rt_priority = 0, int cpu = -1, int64_t adder_period_ns = 1'000'000) {
    return cell.writeSet(
        "side.xml", "v2",
        executor("side", rt_priority, cpu) + thread("counter", "oc_counter_v2.so", cell.dir.path) +
            thread("adder", "oc_adder_v2.so", cell.dir.path, 2, "<executor>side</executor>", adder_period_ns));
}

}  // namespace

TEST(OnlineChange, AnExecutorIsAddedItsThreadStartsBeforeTheSwapAndRunsTheNewModule) {
    Cell cell;
    settle();
    EXPECT_EQ(executorThreads(cell.irpd->pid()).count("side"), 0u);
    const uint64_t counted = cell.u64("oc.counter");
    EXPECT_GT(counted, 0u);
    const json checked = cell.ask({{"cmd", "check"}, {"config", withSide(cell)}})["result"];
    EXPECT_EQ(checked["online"], true) << checked.dump();
    EXPECT_EQ(checked["warnings"], json::array()) << "on main's CPU, which non-RT work was kept off";
    if (cell.irpd->err().find("non-RT work on CPUs 0") != std::string::npos) {
        // CPU 0 is where irpd put its non-RT threads: an executor there shares it until a restart.
        const json warned = cell.ask({{"cmd", "check"}, {"config", withSide(cell, 0, 0)}})["result"];
        ASSERT_EQ(warned["warnings"].size(), 1u) << warned.dump();
        EXPECT_NE(warned["warnings"][0].get<std::string>().find("executor 'side' runs on CPU 0"), std::string::npos);
    }
    json answer = cell.load(withSide(cell));
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    EXPECT_EQ(answer["result"]["kept"], json({"counter"}));
    EXPECT_EQ(answer["result"]["started"], json({"adder"}));
    EXPECT_TRUE(answer["result"]["missed_periods"].is_number_unsigned()) << answer.dump();
    settle();
    EXPECT_EQ(executorThreads(cell.irpd->pid()).count("side"), 1u) << "one thread for executor side";
    const auto by_name = dispatchers(cell);
    ASSERT_EQ(by_name.count("side"), 1u);
    EXPECT_EQ(by_name.at("side")["name"], "dispatcher@side");
    EXPECT_GT(by_name.at("side")["runs"].get<uint64_t>(), 50u);
    const json adder = moduleStats(cell, "adder");
    EXPECT_EQ(adder["executor"], "side");
    EXPECT_GT(adder["runs"].get<uint64_t>(), 50u);
    EXPECT_GT(cell.f64("oc.added"), 0.0) << "the module on the new executor writes its variable";
    EXPECT_GT(cell.u64("oc.counter"), counted) << "the counter on main kept its value and went on counting";
    cell.expectCounterMissedNoPeriod();
}

TEST(OnlineChange, AnExecutorIsRemovedItsModuleMovesToMainAndItsThreadEnds) {
    Cell cell;
    ASSERT_TRUE(cell.load(withSide(cell))["ok"]);
    settle();
    const uint64_t added = moduleStats(cell, "adder")["runs"];
    json answer = cell.load(cell.writeSet("main.xml", "v2",
                                          thread("counter", "oc_counter_v2.so", cell.dir.path) +
                                              thread("adder", "oc_adder_v2.so", cell.dir.path, 2)));
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    EXPECT_EQ(answer["result"]["kept"], json({"counter", "adder"}))
        << "a thread module moved to another executor is kept";
    EXPECT_TRUE(answer["result"]["missed_periods"].is_number_unsigned()) << answer.dump();
    EXPECT_EQ(executorThreads(cell.irpd->pid()).count("side"), 0u) << "the thread was stopped and joined by the swap";
    EXPECT_EQ(dispatchers(cell).count("side"), 0u);
    settle();
    const json adder = moduleStats(cell, "adder");
    EXPECT_EQ(adder["executor"], "main");
    EXPECT_GT(adder["runs"].get<uint64_t>(), added + 50) << "the same instance goes on on main";
    cell.expectCounterMissedNoPeriod();
}

TEST(OnlineChange, AnExecutorWhosePriorityChangesGetsANewThread) {
    Cell cell;
    ASSERT_TRUE(cell.load(withSide(cell, 10))["ok"]);
    settle();
    auto threads = executorThreads(cell.irpd->pid());
    const bool realtime = threads["main"] > 0;  // SCHED_FIFO where irpd may use it
    if (realtime) {
        EXPECT_EQ(threads["side"], 10);
    }
    json answer = cell.load(withSide(cell, 20));
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    EXPECT_EQ(answer["result"]["kept"], json({"counter", "adder"}));
    EXPECT_TRUE(answer["result"]["missed_periods"].is_number_unsigned()) << answer.dump();
    threads = executorThreads(cell.irpd->pid());
    EXPECT_EQ(threads.count("side"), 1u) << "the old thread is gone";
    if (realtime) {
        EXPECT_EQ(threads["side"], 20);
    }
    settle();
    cell.expectCounterMissedNoPeriod();
}

TEST(OnlineChange, AnExecutorWhosePeriodChangesKeepsItsThreadAndRecordOnTheNewGrid) {
    Cell cell;
    ASSERT_TRUE(cell.load(withSide(cell))["ok"]);
    settle();
    const pid_t tid = executorTid(cell.irpd->pid(), "side");
    ASSERT_NE(tid, 0);
    const uint64_t side_runs = dispatchers(cell).at("side")["runs"];
    const uint64_t adder_runs = moduleStats(cell, "adder")["runs"];
    json answer = cell.load(withSide(cell, 0, -1, 2'000'000));
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    EXPECT_EQ(answer["result"]["kept"], json({"counter", "adder"}));
    EXPECT_EQ(answer["result"]["started"], json::array());
    EXPECT_EQ(executorTid(cell.irpd->pid(), "side"), tid) << "the same name, priority and CPU: the same thread";
    settle();
    const json side = dispatchers(cell).at("side");
    EXPECT_EQ(side["period_ns"], 2'000'000) << "its basic period is the adder's new period";
    EXPECT_GT(side["runs"].get<uint64_t>(), side_runs) << "its record goes on";
    const json adder = moduleStats(cell, "adder");
    EXPECT_EQ(adder["period_ns"], 2'000'000);
    EXPECT_GT(adder["runs"].get<uint64_t>(), adder_runs + 50) << "the same instance goes on at 2 ms";
    cell.expectCounterMissedNoPeriod();
}

TEST(OnlineChange, AnExecutorOnACpuIrpdMayNotUseIsRefusedAndNothingChanges) {
    Cell cell;
    const json generation = cell.generation();
    const std::string xml = withSide(cell, 0, 999);
    const json checked = cell.ask({{"cmd", "check"}, {"config", xml}})["result"];
    EXPECT_EQ(checked["valid"], false) << checked.dump();
    json refused = cell.load(xml);
    ASSERT_FALSE(refused.value("ok", true));
    const std::string message = refused["error"]["message"];
    EXPECT_NE(message.find("executor 'side': CPU 999 is not available"), std::string::npos) << message;
    EXPECT_EQ(cell.generation(), generation);
    EXPECT_EQ(executorThreads(cell.irpd->pid()).count("side"), 0u);
    settle();
    cell.expectCounterMissedNoPeriod();
}

TEST(OnlineChange, ANewExecutorWithoutAStatsRecordNamesTheOption) {
    Cell cell("", {"--module-records", "1"});
    const json generation = cell.generation();
    const std::string xml =
        cell.writeSet("side.xml", "v1", executor("side") + thread("counter", "oc_counter_v1.so", cell.dir.path));
    // The dry run says so before anything is loaded.
    const json checked = cell.ask({{"cmd", "check"}, {"config", xml}})["result"];
    EXPECT_EQ(checked["valid"], true) << checked.dump();
    EXPECT_EQ(checked["online"], false) << checked.dump();
    ASSERT_TRUE(checked["restart"].is_object()) << checked.dump();
    EXPECT_NE(checked["restart"]["reason"].get<std::string>().find("--module-records"), std::string::npos)
        << checked.dump();
    json refused = cell.load(xml);
    ASSERT_FALSE(refused.value("ok", true));
    EXPECT_EQ(refused["error"]["code"], "restart_required") << refused.dump();
    const std::string message = refused["error"]["message"];
    EXPECT_NE(message.find("executor 'side'"), std::string::npos) << message;
    EXPECT_NE(message.find("--module-records"), std::string::npos) << message;
    EXPECT_EQ(cell.generation(), generation);
    EXPECT_EQ(executorThreads(cell.irpd->pid()).count("side"), 0u);
    cell.expectCounterMissedNoPeriod();
}

// The same conversion with the new module on an executor the swap adds: the parked thread and main
// both arrive at the swap's gate, and the new module's first run on it already reads converted values.
TEST(OnlineChange, ConvertedVariablesAreReadByANewModuleOnANewExecutor) {
    Cell cell("", {}, "cv1", {"cv", "oc_cv_v1.so"});
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    const int32_t count_before = cell.value<int32_t>("cv.fb.count");
    EXPECT_GT(count_before, 300);
    json answer = cell.load(cell.writeSet(
        "cv2-side.xml", "cv2",
        executor("side", 0, -1) + thread("cv", "oc_cv_v2.so", cell.dir.path, 1, "<executor>side</executor>")));
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    EXPECT_EQ(answer["result"]["variables"]["converted"].size(), 6u) << answer.dump();
    expectConvertedByCv2(cell, count_before);
}
