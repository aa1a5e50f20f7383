// test_schedule.cpp -- the GCD/LCM slot table: the paper's Table 3 for Figure 1 (through build(),
// toJson() and formatText()), Figure 9, several other sets checked slot by slot, and every refusal.
#include "config/module_xml.hpp"
#include "schedule/schedule.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <initializer_list>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using irp::config::SetSpec;
using irp::schedule::build;
using irp::schedule::formatText;
using irp::schedule::Limits;
using irp::schedule::Schedule;
using irp::schedule::toJson;
using Names = std::vector<std::string>;

namespace {

// ---- shared fragments ------------------------------------------------------------------------

const std::string kSetPath = "/sets/test/module.xml";

std::string periodic(const std::string &name, int64_t period_ns, int priority, const std::string &extra = "") {
    return "  <module><filename>./" + name +
           ".so</filename><moduletype>thread</moduletype>"
           "<operationtype>periodic</operationtype><period>" +
           std::to_string(period_ns) + "</period><priority>" + std::to_string(priority) + "</priority>" + extra +
           "</module>\n";
}

std::string periodicProcess(const std::string &name, int64_t period_ns, int priority) {
    return "  <module><filename>./" + name +
           ".exe</filename><moduletype>process</moduletype>"
           "<operationtype>periodic</operationtype><period>" +
           std::to_string(period_ns) + "</period><priority>" + std::to_string(priority) + "</priority></module>\n";
}

std::string sporadic(const std::string &name, int64_t deadline_ns, int priority) {
    return "  <module><filename>./" + name +
           ".so</filename><moduletype>thread</moduletype>"
           "<operationtype>sporadic</operationtype><deadline>" +
           std::to_string(deadline_ns) + "</deadline><priority>" + std::to_string(priority) + "</priority></module>\n";
}

std::string nonReal(const std::string &name) {
    return "  <module><filename>./" + name +
           ".exe</filename><moduletype>process</moduletype>"
           "<operationtype>non-real</operationtype></module>\n";
}

std::string executor(const std::string &name) { return "  <executor><name>" + name + "</name></executor>\n"; }

// A set from module fragments, through the real parser.
SetSpec setOf(const std::vector<std::string> &parts) {
    std::string text = "<?xml version=\"1.0\"?>\n<root>\n";
    for (const std::string &p : parts) text += p;
    text += "</root>\n";
    auto parsed = irp::config::parseModuleXmlText(text, kSetPath);
    EXPECT_TRUE(parsed.ok()) << parsed.error().message << "\n" << text;
    return parsed.ok() ? std::move(parsed).value() : SetSpec{};
}

// A paper figure's module.xml: Figure 1 is the paper-fig1 set's own, the others are fixtures.
SetSpec figure(const char *file) {
    const fs::path path = std::string(file) == "fig1-module.xml"
                              ? fs::path(SOURCE_ROOT) / "config/sets/paper-fig1/module.xml"
                              : fs::path(FIXTURE_FILES) / file;
    auto parsed = irp::config::parseModuleXml(path);
    EXPECT_TRUE(parsed.ok()) << parsed.error().message;
    return parsed.ok() ? std::move(parsed).value() : SetSpec{};
}

Schedule built(const SetSpec &set, const Limits &limits = {}) {
    auto s = build(set, limits);
    EXPECT_TRUE(s.ok()) << s.error().message;
    return s.ok() ? std::move(s).value() : Schedule{};
}

// The slot table as module names, slot by slot.
std::vector<Names> namesBySlot(const Schedule &s, const SetSpec &set) {
    std::vector<Names> out;
    for (const auto &slot : s.slots) {
        Names names;
        for (int i : slot.modules) names.push_back(set.modules.at(static_cast<std::size_t>(i)).name);
        out.push_back(names);
    }
    return out;
}

// Index, offset and count are consistent: slot i starts at i * basic, macro / basic slots.
void expectWellFormed(const Schedule &s) {
    ASSERT_GT(s.basic_ns, 0);
    ASSERT_EQ(s.macro_ns % s.basic_ns, 0);
    ASSERT_EQ(s.slots.size(), static_cast<std::size_t>(s.macro_ns / s.basic_ns));
    for (std::size_t i = 0; i < s.slots.size(); ++i) {
        EXPECT_EQ(s.slots[i].index, i);
        EXPECT_EQ(s.slots[i].offset_ns, static_cast<int64_t>(i) * s.basic_ns);
    }
}

// The message must be one line starting with the set's path and holding every piece.
::testing::AssertionResult refused(const SetSpec &set, const Limits &limits,
                                   std::initializer_list<std::string> pieces) {
    auto s = build(set, limits);
    if (s.ok()) return ::testing::AssertionFailure() << "accepted: " << s->slots.size() << " slots";
    const std::string &message = s.error().message;
    if (message.find('\n') != std::string::npos) return ::testing::AssertionFailure() << "not one line: " << message;
    if (message.rfind(kSetPath + ":", 0) != 0)
        return ::testing::AssertionFailure() << "does not start with " << kSetPath << ": " << message;
    for (const std::string &piece : pieces)
        if (message.find(piece) == std::string::npos)
            return ::testing::AssertionFailure() << "lacks '" << piece << "': " << message;
    return ::testing::AssertionSuccess() << message;
}

// formatText's lines with runs of spaces collapsed to one, trailing spaces dropped.
std::vector<std::string> textLines(const std::string &text) {
    std::vector<std::string> lines;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
        std::string collapsed;
        for (char c : line)
            if (!(c == ' ' && (collapsed.empty() || collapsed.back() == ' '))) collapsed += c;
        while (!collapsed.empty() && collapsed.back() == ' ') collapsed.pop_back();
        lines.push_back(collapsed);
    }
    return lines;
}

}  // namespace

// ---- Table 3: the paper's Figure 1 ------------------------------------------------------------

TEST(ScheduleTable3, Figure1BasicAndMacroPeriod) {
    SetSpec set = figure("fig1-module.xml");
    Schedule s = built(set);
    EXPECT_EQ(s.basic_ns, 100'000);
    EXPECT_EQ(s.macro_ns, 500'000);
    expectWellFormed(s);
}

TEST(ScheduleTable3, Figure1SlotsAreTable3) {
    SetSpec set = figure("fig1-module.xml");
    Schedule s = built(set);
    ASSERT_EQ(s.slots.size(), 5u);
    EXPECT_EQ(namesBySlot(s, set), (std::vector<Names>{
                                       {"cntr3", "cntr2", "cntr1", "cntr4"},
                                       {"cntr3", "cntr2"},
                                       {"cntr3", "cntr2"},
                                       {"cntr3", "cntr2"},
                                       {"cntr3", "cntr2"},
                                   }));
    for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ(s.slots[i].offset_ns, static_cast<int64_t>(i) * 100'000);
    // Indices into SetSpec::modules: cntr3 is the third module of the file, cntr4 the fourth.
    EXPECT_EQ(s.slots[0].modules, (std::vector<int>{2, 1, 0, 3}));
}

TEST(ScheduleTable3, Figure1Json) {
    SetSpec set = figure("fig1-module.xml");
    nlohmann::ordered_json json = toJson(built(set), set);
    const auto expected = nlohmann::ordered_json::parse(R"({
        "basic_period_ns": 100000,
        "macro_period_ns": 500000,
        "slots": [
            {"index": 0, "offset_ns": 0,      "modules": ["cntr3", "cntr2", "cntr1", "cntr4"]},
            {"index": 1, "offset_ns": 100000, "modules": ["cntr3", "cntr2"]},
            {"index": 2, "offset_ns": 200000, "modules": ["cntr3", "cntr2"]},
            {"index": 3, "offset_ns": 300000, "modules": ["cntr3", "cntr2"]},
            {"index": 4, "offset_ns": 400000, "modules": ["cntr3", "cntr2"]}
        ]})");
    nlohmann::ordered_json table = json;
    table.erase("modules");  // the per-module summary that follows the table
    EXPECT_EQ(table, expected);
    EXPECT_EQ(table.dump(), expected.dump()) << "keys in the documented order";
    EXPECT_TRUE(json["basic_period_ns"].is_number_integer());
    EXPECT_TRUE(json["slots"][0]["index"].is_number_integer());
}

TEST(ScheduleTable3, Figure1JsonModuleSummary) {
    SetSpec set = figure("fig1-module.xml");
    nlohmann::ordered_json json = toJson(built(set), set);
    ASSERT_TRUE(json.contains("modules"));
    ASSERT_EQ(json["modules"].size(), 7u);
    EXPECT_EQ(json["modules"][0], nlohmann::ordered_json::parse(R"({"name": "cntr1", "moduletype": "thread",
        "operationtype": "periodic", "period_ns": 500000, "deadline_ns": 0, "priority": 3, "executor": "main"})"));
    EXPECT_EQ(json["modules"][5], nlohmann::ordered_json::parse(R"({"name": "visionEvt", "moduletype": "process",
        "operationtype": "sporadic", "period_ns": 0, "deadline_ns": 100000000, "priority": 2, "executor": "main"})"));
    EXPECT_EQ(json["modules"][6]["operationtype"], "non-real");
}

TEST(ScheduleTable3, Figure1Text) {
    SetSpec set = figure("fig1-module.xml");
    std::vector<std::string> lines = textLines(formatText(built(set), set));
    ASSERT_GE(lines.size(), 11u) << formatText(built(set), set);
    EXPECT_EQ(lines[0], "basic period 100000 ns (100 us), macro period 500000 ns (500 us), 5 slots");
    EXPECT_EQ(lines[1], "slot offset_ns modules (in priority order)");
    EXPECT_EQ(lines[2], "0 0 cntr3 > cntr2 > cntr1 > cntr4");
    EXPECT_EQ(lines[3], "1 100000 cntr3 > cntr2");
    EXPECT_EQ(lines[4], "2 200000 cntr3 > cntr2");
    EXPECT_EQ(lines[5], "3 300000 cntr3 > cntr2");
    EXPECT_EQ(lines[6], "4 400000 cntr3 > cntr2");
    EXPECT_EQ(lines[7], "outside the slot table:");
    EXPECT_EQ(lines[8].rfind("event1 (sporadic thread, deadline 1000000 ns, priority 1", 0), 0u) << lines[8];
    EXPECT_EQ(lines[9].rfind("visionEvt (sporadic process, deadline 100000000 ns, priority 2", 0), 0u) << lines[9];
    EXPECT_EQ(lines[10].rfind("nonReaTime (non-real process", 0), 0u) << lines[10];
    EXPECT_EQ(lines.size(), 11u) << "no executor note: every module runs on main";
}

// ---- other sets -------------------------------------------------------------------------------

TEST(Schedule, Figure9IsOneSlotOf10msRobotFirst) {
    SetSpec set = figure("fig9-module.xml");
    Schedule s = built(set);
    EXPECT_EQ(s.basic_ns, 10'000'000);
    EXPECT_EQ(s.macro_ns, 10'000'000);
    expectWellFormed(s);
    EXPECT_EQ(namesBySlot(s, set), (std::vector<Names>{{"Robot", "main"}}));  // priority 2 before 3
    std::vector<std::string> lines = textLines(formatText(s, set));
    ASSERT_EQ(lines.size(), 3u);
    EXPECT_EQ(lines[0], "basic period 10000000 ns (10 ms), macro period 10000000 ns (10 ms), 1 slot");
    EXPECT_EQ(lines[2], "0 0 Robot > main");
}

TEST(Schedule, Periods200And300us) {
    // GCD 100 us, LCM 600 us; the 300 us module has the higher priority.
    SetSpec set = setOf({periodic("a", 200'000, 2), periodic("b", 300'000, 1)});
    Schedule s = built(set);
    EXPECT_EQ(s.basic_ns, 100'000);
    EXPECT_EQ(s.macro_ns, 600'000);
    expectWellFormed(s);
    EXPECT_EQ(namesBySlot(s, set), (std::vector<Names>{{"b", "a"}, {}, {"a"}, {"b"}, {"a"}, {}}));
    std::vector<std::string> lines = textLines(formatText(s, set));
    ASSERT_GE(lines.size(), 8u);
    EXPECT_EQ(lines[3], "1 100000");  // an empty slot
    EXPECT_EQ(lines[5], "3 300000 b");
}

TEST(Schedule, Periods100_150_250us) {
    // GCD 50 us, LCM 1500 us: 30 slots.
    SetSpec set = setOf({periodic("fast", 100'000, 1), periodic("mid", 150'000, 2), periodic("slow", 250'000, 3)});
    Schedule s = built(set);
    EXPECT_EQ(s.basic_ns, 50'000);
    EXPECT_EQ(s.macro_ns, 1'500'000);
    expectWellFormed(s);
    auto names = namesBySlot(s, set);
    ASSERT_EQ(names.size(), 30u);
    EXPECT_EQ(names[0], (Names{"fast", "mid", "slow"}));
    EXPECT_EQ(names[1], (Names{}));
    EXPECT_EQ(names[2], (Names{"fast"}));
    EXPECT_EQ(names[3], (Names{"mid"}));
    EXPECT_EQ(names[5], (Names{"slow"}));
    EXPECT_EQ(names[6], (Names{"fast", "mid"}));
    EXPECT_EQ(names[10], (Names{"fast", "slow"}));
    EXPECT_EQ(names[15], (Names{"mid", "slow"}));
    EXPECT_EQ(names[29], (Names{}));
}

TEST(Schedule, HarmonicPeriods) {
    SetSpec set = setOf({periodic("p4", 4'000'000, 1), periodic("p1", 1'000'000, 3), periodic("p2", 2'000'000, 2)});
    Schedule s = built(set);
    EXPECT_EQ(s.basic_ns, 1'000'000);
    EXPECT_EQ(s.macro_ns, 4'000'000);
    EXPECT_EQ(namesBySlot(s, set), (std::vector<Names>{{"p4", "p2", "p1"}, {"p1"}, {"p2", "p1"}, {"p1"}}));
}

TEST(Schedule, SingleModule) {
    SetSpec set = setOf({periodic("only", 1'000'000, 5)});
    Schedule s = built(set);
    EXPECT_EQ(s.basic_ns, 1'000'000);
    EXPECT_EQ(s.macro_ns, 1'000'000);
    expectWellFormed(s);
    EXPECT_EQ(namesBySlot(s, set), (std::vector<Names>{{"only"}}));
}

TEST(Schedule, EqualPrioritiesRunInFileOrder) {
    // zeta, alpha, mid share priority 1 and keep the file's order (not the name's); top (0) goes first.
    SetSpec set = setOf({periodic("zeta", 100'000, 1), periodic("alpha", 100'000, 1), periodic("top", 200'000, 0),
                         periodic("mid", 100'000, 1)});
    Schedule s = built(set);
    EXPECT_EQ(namesBySlot(s, set), (std::vector<Names>{{"top", "zeta", "alpha", "mid"}, {"zeta", "alpha", "mid"}}));
}

TEST(Schedule, PriorityNotFileOrderDecides) {
    SetSpec set = setOf({periodic("c", 100'000, 30), periodic("b", 100'000, 20), periodic("a", 100'000, 10)});
    EXPECT_EQ(namesBySlot(built(set), set), (std::vector<Names>{{"a", "b", "c"}}));
}

TEST(Schedule, PeriodicProcessesShareTheTable) {
    SetSpec set = setOf({periodic("thr", 100'000, 2), periodicProcess("proc", 200'000, 1)});
    Schedule s = built(set);
    EXPECT_EQ(s.basic_ns, 100'000);
    EXPECT_EQ(namesBySlot(s, set), (std::vector<Names>{{"proc", "thr"}, {"thr"}}));
}

TEST(Schedule, SporadicAndNonRealAreOutsideTheSlots) {
    // A sporadic deadline of 30 us does not lower the basic period: only periods count.
    SetSpec set = setOf({sporadic("evt", 30'000, 0), periodic("ctl", 100'000, 1), nonReal("log")});
    Schedule s = built(set);
    EXPECT_EQ(s.basic_ns, 100'000);
    EXPECT_EQ(namesBySlot(s, set), (std::vector<Names>{{"ctl"}}));
    std::vector<std::string> lines = textLines(formatText(s, set));
    ASSERT_EQ(lines.size(), 6u) << formatText(s, set);
    EXPECT_EQ(lines[3], "outside the slot table:");
    EXPECT_EQ(lines[4].rfind("evt (sporadic thread, deadline 30000 ns, priority 0", 0), 0u) << lines[4];
    EXPECT_EQ(lines[5].rfind("log (non-real process", 0), 0u) << lines[5];
}

TEST(Schedule, NoOutsideSectionWhenEveryModuleIsPeriodic) {
    SetSpec set = setOf({periodic("ctl", 100'000, 1)});
    EXPECT_EQ(formatText(built(set), set).find("outside the slot table"), std::string::npos);
}

TEST(Schedule, ExecutorModulesShowAsNameAtExecutor) {
    SetSpec set = setOf({executor("io"), periodic("drive", 100'000, 1, "<executor>io</executor>"),
                         periodic("ctl", 200'000, 2), sporadic("evt", 100'000, 3)});
    Schedule s = built(set);
    EXPECT_EQ(namesBySlot(s, set), (std::vector<Names>{{"drive", "ctl"}, {"drive"}}));
    std::vector<std::string> lines = textLines(formatText(s, set));
    ASSERT_GE(lines.size(), 4u);
    EXPECT_EQ(lines[2], "0 0 drive@io > ctl");
    EXPECT_EQ(lines[3], "1 100000 drive@io");
    EXPECT_NE(formatText(s, set).find("name@executor:"), std::string::npos) << "the notation is explained";
    // JSON keeps plain names in the slots and says the executor per module.
    nlohmann::ordered_json json = toJson(s, set);
    EXPECT_EQ(json["slots"][0]["modules"], nlohmann::ordered_json::parse(R"(["drive", "ctl"])"));
    EXPECT_EQ(json["modules"][0]["executor"], "io");
    EXPECT_EQ(json["modules"][1]["executor"], "main");
}

TEST(Schedule, EverySlotHoldsTheModulesWhosePeriodDividesItsOffset) {
    // Brute force against the definition, for a few sets.
    const std::vector<std::vector<std::pair<int64_t, int>>> sets = {
        {{100'000, 1}, {150'000, 1}, {400'000, 2}},
        {{600'000, 3}, {900'000, 2}, {1'200'000, 1}, {1'800'000, 0}},
        {{1'000'000, 1}, {3'000'000, 1}, {7'000'000, 2}},
        {{250'000, 2}, {500'000, 1}, {750'000, 0}},
    };
    for (const auto &periods : sets) {
        std::vector<std::string> parts;
        for (std::size_t i = 0; i < periods.size(); ++i)
            parts.push_back(periodic("m" + std::to_string(i), periods[i].first, periods[i].second));
        SetSpec set = setOf(parts);
        int64_t gcd = 0, lcm = 1;
        for (const auto &[p, prio] : periods) {
            gcd = std::gcd(gcd, p);
            lcm = std::lcm(lcm, p);
        }
        SCOPED_TRACE("basic " + std::to_string(gcd) + ", macro " + std::to_string(lcm));
        Schedule s = built(set);
        EXPECT_EQ(s.basic_ns, gcd);
        EXPECT_EQ(s.macro_ns, lcm);
        expectWellFormed(s);
        for (const auto &slot : s.slots) {
            std::vector<int> due;
            for (std::size_t i = 0; i < periods.size(); ++i)
                if (slot.offset_ns % periods[i].first == 0) due.push_back(static_cast<int>(i));
            std::stable_sort(due.begin(), due.end(),
                             [&](int a, int b) { return periods[a].second < periods[b].second; });
            EXPECT_EQ(slot.modules, due) << "slot " << slot.index;
        }
    }
}

// ---- refused sets -----------------------------------------------------------------------------

TEST(ScheduleRefused, DefaultMinimumBasicPeriodIs50us) {
    EXPECT_EQ(Limits{}.min_basic_ns, 50'000);
    SetSpec set = setOf({periodic("a", 50'000, 1)});
    EXPECT_EQ(built(set).basic_ns, 50'000);  // exactly the minimum is fine
}

TEST(ScheduleRefused, PeriodBelowTheMinimum) {
    SetSpec set = setOf({periodic("a", 40'000, 1)});
    EXPECT_TRUE(refused(
        set, {},
        {"basic period (GCD of the periods) is 40000 ns", "below the minimum basic period of 50000 ns", "50 us"}));
}

TEST(ScheduleRefused, GcdBelowTheMinimumThoughEveryPeriodIsAbove) {
    // 100 us and 130 us: each fine alone, but their GCD is 10 us.
    SetSpec set = setOf({periodic("a", 100'000, 1), periodic("b", 130'000, 2)});
    EXPECT_TRUE(refused(set, {}, {"is 10000 ns", "below the minimum basic period of 50000 ns"}));
}

TEST(ScheduleRefused, MinimumIsConfigurable) {
    SetSpec fast = setOf({periodic("a", 20'000, 1), periodic("b", 40'000, 2)});
    Limits lower;
    lower.min_basic_ns = 10'000;
    EXPECT_EQ(built(fast, lower).basic_ns, 20'000);

    Limits higher;
    higher.min_basic_ns = 200'000;
    SetSpec fig1 = figure("fig1-module.xml");
    auto s = build(fig1, higher);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("is 100000 ns, below the minimum basic period of 200000 ns"), std::string::npos)
        << s.error().message;
    EXPECT_NE(s.error().message.find("200 us"), std::string::npos) << s.error().message;
}

TEST(ScheduleRefused, TooManySlots) {
    // 50 ms and 50.05 ms: GCD 50 us, LCM 1000 * 1001 basic periods.
    SetSpec set = setOf({periodic("a", 50'000'000, 1), periodic("b", 50'050'000, 2)});
    EXPECT_TRUE(refused(set, {},
                        {"macro period (LCM of the periods) is 50050000000 ns", "1001000 basic periods",
                         "at most 100000", "multiples of each other"}));
}

TEST(ScheduleRefused, MaxSlotsIsConfigurable) {
    SetSpec fig1 = figure("fig1-module.xml");
    Limits five;
    five.max_slots = 5;
    EXPECT_EQ(built(fig1, five).slots.size(), 5u);
    Limits four;
    four.max_slots = 4;
    auto s = build(fig1, four);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("5 basic periods"), std::string::npos) << s.error().message;
    EXPECT_NE(s.error().message.find("at most 4"), std::string::npos) << s.error().message;
}

TEST(ScheduleRefused, LcmOverflow) {
    // 50 us * 2^24 and 50 us * (2^24 - 1): co-prime multiples whose LCM is beyond 2^63 ns.
    const int64_t a = 50'000LL << 24, b = 50'000LL * ((1LL << 24) - 1);
    SetSpec set = setOf({periodic("a", a, 1), periodic("b", b, 2)});
    EXPECT_TRUE(refused(set, {}, {kSetPath + ":4: module 'b'", "no common multiple below 2^63 ns"}));
}

TEST(ScheduleRefused, NoPeriodicModule) {
    SetSpec set = setOf({sporadic("evt", 1'000'000, 1), nonReal("log")});
    EXPECT_TRUE(refused(set, {}, {"no periodic module", "basic period"}));
}

TEST(ScheduleRefused, EmptySet) {
    SetSpec set = setOf({});
    EXPECT_TRUE(set.modules.empty());
    EXPECT_TRUE(refused(set, {}, {"no periodic module"}));
}

// ---- durations for people ---------------------------------------------------------------------

TEST(Schedule, HumanDuration) {
    using irp::schedule::humanDuration;
    EXPECT_EQ(humanDuration(999), "999 ns");
    EXPECT_EQ(humanDuration(50'000), "50 us");
    EXPECT_EQ(humanDuration(100'000), "100 us");
    EXPECT_EQ(humanDuration(1'500'000), "1.5 ms");
    EXPECT_EQ(humanDuration(10'000'000), "10 ms");
    EXPECT_EQ(humanDuration(2'000'000'000), "2 s");
}
