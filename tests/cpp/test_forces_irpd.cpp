// test_forces_irpd.cpp -- forcing in a running irpd through its control socket (docs/forcing.md): a
// thread module and a process module that write a forced variable every period never leave their
// value for the module after them, nor for a reader once the dispatchers stopped after a slot;
// unforce keeps or restores the value; a write to a forced variable is refused naming who forced
// it; a force survives an online change that keeps its variable and is dropped with an event when
// the variable is removed.
#include "support/online_cell.hpp"

using namespace online_cell;

namespace {

json force(Cell &cell, const std::string &path, const json &value, const std::string &by = "tester") {
    return cell.ask({{"cmd", "force"}, {"path", path}, {"value", value}, {"by", by}});
}

json unforce(Cell &cell, const std::string &path, bool restore) {
    return cell.ask({{"cmd", "unforce"}, {"path", path}, {"restore", restore}});
}

// Every value `read` gives over ~300 ms of periods.
template <class Read>
void expectAlways(Read read, double expected, const char *what) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(300);
    int reads = 0;
    while (std::chrono::steady_clock::now() < until) {
        ASSERT_EQ(read(), expected) << what << " after " << reads << " reads";
        ++reads;
        std::this_thread::sleep_for(std::chrono::microseconds(50));
    }
}

std::string events(Cell &cell) { return cell.ask({{"cmd", "events"}})["result"]["events"].dump(); }

// The variables as the dispatchers left them when they stopped after their last slot (the segment
// stays mapped here after irpd removed its name).
void stopIrpd(Cell &cell) {
    kill(cell.irpd->pid(), SIGTERM);
    ASSERT_EQ(cell.irpd->wait(std::chrono::seconds(10)), 0) << cell.irpd->err();
}

}  // namespace

TEST(Forces, AThreadModuleWritingAForcedVariableEveryPeriodLeavesItToNobody) {
    Cell cell;
    ASSERT_TRUE(cell.load(cell.writeSet("v2.xml", "v2",
                                        thread("counter", "oc_counter_v2.so", cell.dir.path) +
                                            thread("adder", "oc_adder_v2.so", cell.dir.path, 2)))["ok"]);
    settle();
    const json answer = force(cell, "oc.counter", 7);
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    EXPECT_EQ(answer["result"]["value"], 7);
    EXPECT_EQ(answer["result"]["by"], "tester");
    EXPECT_EQ(answer["result"]["type"], "uint64_t");
    EXPECT_GT(answer["result"]["before"].get<uint64_t>(), 0u) << "the counter's value when forced";
    settle();
    // The adder runs right after the counter, which adds 1 to oc.counter every period.
    expectAlways([&] { return cell.f64("oc.added"); }, 7.0, "what the next module read");
    EXPECT_EQ(cell.ask({{"cmd", "status"}})["result"]["forces"], 1);
    const json listed = cell.ask({{"cmd", "forces"}})["result"];
    ASSERT_EQ(listed["forces"].size(), 1u) << listed.dump();
    EXPECT_EQ(listed["forces"][0]["path"], "oc.counter");
    EXPECT_EQ(listed["max_forces"], 256);
    EXPECT_NE(events(cell).find("'oc.counter' forced to 7 by tester"), std::string::npos) << events(cell);
    stopIrpd(cell);
    EXPECT_EQ(cell.u64("oc.counter"), 7u) << "after the last slot";
}

TEST(Forces, AProcessModuleWritingAForcedVariableEveryPeriodLeavesItToNobody) {
    Cell cell;
    ASSERT_TRUE(cell.load(cell.writeSet("v2.xml", "v2",
                                        thread("counter", "oc_counter_v2.so", cell.dir.path) +
                                            process("proc", "oc_proc_v1.exe", 5) +
                                            thread("mirror", "oc_mirror_v2.so", cell.dir.path, 6)))["ok"]);
    settle();
    ASSERT_GT(cell.u64("oc.proc_runs"), 0u) << "the process runs";
    ASSERT_TRUE(force(cell, "oc.proc_runs", 3)["ok"]);
    settle();
    // The mirror runs after the process, which adds 1 to oc.proc_runs every period.
    expectAlways([&] { return cell.f64("oc.added"); }, 3.0, "what the module after the process read");
    stopIrpd(cell);
    EXPECT_EQ(cell.u64("oc.proc_runs"), 3u) << "after the last slot";
}

TEST(Forces, UnforceKeepsTheForcedValueOrRestoresTheOneBefore) {
    Cell cell;
    int32_t gone = 0;
    ASSERT_TRUE(force(cell, "oc.gone", 5)["ok"]);
    EXPECT_EQ(cell.value<int32_t>("oc.gone"), 5);
    json kept = unforce(cell, "oc.gone", false);
    ASSERT_TRUE(kept.value("ok", false)) << kept.dump();
    EXPECT_EQ(kept["result"]["left"], 5);
    EXPECT_EQ(kept["result"]["force"]["before"], 0);
    EXPECT_EQ(cell.value<int32_t>("oc.gone"), 5) << "unforce without restore keeps the value";
    ASSERT_TRUE(force(cell, "oc.gone", -9, "alice")["ok"]);
    ASSERT_TRUE(force(cell, "oc.gone", -8, "bob")["ok"]) << "forced again: the value replaced";
    json restored = unforce(cell, "oc.gone", true);
    ASSERT_TRUE(restored.value("ok", false)) << restored.dump();
    EXPECT_EQ(restored["result"]["force"]["by"], "bob");
    EXPECT_EQ(restored["result"]["force"]["value"], -8);
    EXPECT_EQ(restored["result"]["left"], 5) << "the value before the first force";
    gone = cell.value<int32_t>("oc.gone");
    EXPECT_EQ(gone, 5);
    json again = unforce(cell, "oc.gone", true);
    EXPECT_EQ(again["error"]["code"], "not_found") << again.dump();
    EXPECT_NE(events(cell).find("'oc.gone' no longer forced (forced by bob), restored to 5"), std::string::npos);
}

TEST(Forces, AWriteToAForcedVariableIsRefusedNamingWhoForcedIt) {
    Cell cell;
    ASSERT_TRUE(force(cell, "oc.gone", 5, "alice")["ok"]);
    const json refused = cell.ask({{"cmd", "write"}, {"path", "oc.gone"}, {"value", 6}});
    ASSERT_FALSE(refused.value("ok", true)) << refused.dump();
    EXPECT_EQ(refused["error"]["code"], "forced") << "its own code (protocol/control.json), not refused";
    const std::string message = refused["error"]["message"];
    EXPECT_NE(message.find("forced by alice"), std::string::npos) << message;
    EXPECT_NE(message.find("unforce it first"), std::string::npos) << message;
    EXPECT_EQ(cell.value<int32_t>("oc.gone"), 5);
    const json unknown = force(cell, "oc.nothing", 1);
    EXPECT_NE(unknown["error"]["message"].get<std::string>().find("no variable 'oc.nothing'"), std::string::npos)
        << unknown.dump();
    const json mistyped = force(cell, "oc.gone", 1.5);
    EXPECT_NE(mistyped["error"]["message"].get<std::string>().find("give an integer"), std::string::npos)
        << mistyped.dump();
}

TEST(Forces, AForceSurvivesAnOnlineChangeThatKeepsItsVariableAndIsDroppedWhenItIsRemoved) {
    Cell cell;
    settle();
    ASSERT_TRUE(force(cell, "oc.counter", 7)["ok"]);
    ASSERT_TRUE(force(cell, "oc.gone", 5)["ok"]);
    json answer = cell.load(cell.writeSet("v2.xml", "v2",
                                          thread("counter", "oc_counter_v2.so", cell.dir.path) +
                                              thread("adder", "oc_adder_v2.so", cell.dir.path, 2)));
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    settle();
    EXPECT_EQ(cell.ask({{"cmd", "forces"}})["result"]["forces"].size(), 2u);
    expectAlways([&] { return cell.f64("oc.added"); }, 7.0, "the new module reads the force kept over the swap");
    answer = cell.load(cell.writeSet("v3.xml", "v3", thread("counter", "oc_counter_v2.so", cell.dir.path)));
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    const json forces = cell.ask({{"cmd", "forces"}})["result"]["forces"];
    ASSERT_EQ(forces.size(), 1u) << forces.dump();
    EXPECT_EQ(forces[0]["path"], "oc.counter");
    const std::string log = events(cell);
    EXPECT_NE(log.find("force_dropped"), std::string::npos) << log;
    EXPECT_NE(log.find("force of 'oc.gone' (by tester) dropped by the new layout: no variable 'oc.gone'"),
              std::string::npos)
        << log;
    settle();
    EXPECT_EQ(cell.u64("oc.counter"), 7u);
}
