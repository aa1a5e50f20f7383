// test_module_xml.cpp -- module.xml: the paper's Figures 1 and 9 as printed, and one named test per
// malformed input, each checking that the refusal names file:line, the module, the field and what
// was expected, on one line.
#include "config/module_xml.hpp"
#include "support/module_xml_text.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace fs = std::filesystem;
using irp::config::ModuleSpec;
using irp::config::ModuleType;
using irp::config::OperationType;
using irp::config::parseModuleXml;
using irp::config::parseModuleXmlText;
using irp::config::SetSpec;
using namespace module_xml_text;

namespace {

std::string readFile(const fs::path &path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A scratch folder for the tests that need real files; removed at the end of the test.
class ScratchDir {
public:
    ScratchDir() {
        const auto *info = ::testing::UnitTest::GetInstance()->current_test_info();
        path_ = fs::path(::testing::TempDir()) / ("irp-module-xml-" + std::string(info->name()));
        fs::remove_all(path_);
        fs::create_directories(path_);
    }
    ~ScratchDir() {
        std::error_code ec;
        fs::remove_all(path_, ec);
    }
    const fs::path &path() const { return path_; }

private:
    fs::path path_;
};

const fs::path kFixtures = FIXTURE_FILES;

}  // namespace

// ---- the paper's figures, as printed ----------------------------------------------------------

struct Expected {
    const char *name;
    const char *filename;
    ModuleType type;
    OperationType operation;
    int64_t period_ns;
    int64_t deadline_ns;
    int priority;
    int line;
    std::vector<std::pair<std::string, std::string>> properties;
};

static void expectModules(const SetSpec &set, const fs::path &xml, const std::vector<Expected> &expected) {
    ASSERT_EQ(set.modules.size(), expected.size());
    EXPECT_TRUE(set.executors.empty());
    EXPECT_EQ(set.xml_path, xml.lexically_normal());
    for (std::size_t i = 0; i < expected.size(); ++i) {
        const Expected &e = expected[i];
        const ModuleSpec &m = set.modules[i];
        SCOPED_TRACE(e.name);
        EXPECT_EQ(m.name, e.name);
        EXPECT_EQ(m.filename, e.filename);
        EXPECT_EQ(m.path, (xml.parent_path() / e.filename).lexically_normal());
        EXPECT_EQ(m.type, e.type);
        EXPECT_EQ(m.operation, e.operation);
        EXPECT_EQ(m.period_ns, e.period_ns);
        EXPECT_EQ(m.deadline_ns, e.deadline_ns);
        EXPECT_EQ(m.priority, e.priority);
        EXPECT_EQ(m.budget_ns, 0);
        EXPECT_EQ(m.executor, "main");
        EXPECT_EQ(m.properties, e.properties);
        EXPECT_EQ(m.index, static_cast<int>(i));
        EXPECT_EQ(m.line, e.line);
        EXPECT_EQ(m.where, xml.string() + ":" + std::to_string(e.line));
    }
}

TEST(PaperFigures, Figure1LoadsAsPrinted) {
    const fs::path xml = fs::path(SOURCE_ROOT) / "config/sets/paper-fig1/module.xml";  // Figure 1, kept once
    auto set = parseModuleXml(xml);
    ASSERT_TRUE(set.ok()) << set.error().message;
    using enum ModuleType;
    using enum OperationType;
    expectModules(*set, xml,
                  {
                      // the paper's own spelling: "intialize_value"
                      {"cntr1", "./cntr1.so", Thread, Periodic, 500000, 0, 3, 9, {{"intialize_value", "5"}}},
                      {"cntr2", "./cntr2.so", Thread, Periodic, 100000, 0, 2, 19, {}},
                      {"cntr3", "./cntr3.so", Thread, Periodic, 100000, 0, 1, 26, {}},
                      {"cntr4", "./cntr4.exe", Process, Periodic, 500000, 0, 4, 33, {}},
                      {"event1", "./event1.so", Thread, Sporadic, 0, 1000000, 1, 40, {}},
                      {"visionEvt", "./visionEvt.exe", Process, Sporadic, 0, 100000000, 2, 47, {}},
                      {"nonReaTime", "./nonReaTime.exe", Process, NonReal, 0, 0, 0, 54, {}},
                  });
}

TEST(PaperFigures, Figure9LoadsAsPrintedWithoutTheCommentedOutModule) {
    const fs::path xml = kFixtures / "fig9-module.xml";
    auto set = parseModuleXml(xml);
    ASSERT_TRUE(set.ok()) << set.error().message;
    using enum ModuleType;
    using enum OperationType;
    expectModules(*set, xml,
                  {
                      {"main", "./build/main.so", Thread, Periodic, 10000000, 0, 3, 3, {{"counter", "5"}}},
                      {"Robot", "./build/Robot.so", Thread, Periodic, 10000000, 0, 2, 13, {{"counter", "5"}}},
                  });
    // "./build/main.so" next to the XML, normalised: no "." component left.
    EXPECT_EQ(set->modules[0].path, kFixtures.lexically_normal() / "build" / "main.so");
    EXPECT_EQ(find(*set, "libiodispat"), nullptr) << "the <!--module> ... </module!--> block is a comment";
}

TEST(PaperFigures, RepoCopiesAreByteIdenticalToThePaper) {
    const fs::path reference = fs::path(SOURCE_ROOT) / ".." / "shared" / "reference" / "figures";
    if (!fs::is_directory(reference)) GTEST_SKIP() << reference << " is not here; nothing to compare with";
    const fs::path root = SOURCE_ROOT;
    const std::pair<fs::path, fs::path> copies[] = {
        {root / "tests/cpp/fixtures/fig9-module.xml", reference / "fig9-module.xml"},
        {root / "config/sets/paper-fig1/module.xml", reference / "fig1-module.xml"},
    };
    for (const auto &[copy, paper] : copies) {
        ASSERT_TRUE(fs::is_regular_file(copy)) << copy;
        ASSERT_TRUE(fs::is_regular_file(paper)) << paper;
        EXPECT_EQ(readFile(copy), readFile(paper)) << copy << " differs from " << paper;
    }
}

TEST(PaperFigures, TheShippedFigure1SetParses) {
    auto set = parseModuleXml(fs::path(SOURCE_ROOT) / "config/sets/paper-fig1/module.xml");
    ASSERT_TRUE(set.ok()) << set.error().message;
    EXPECT_EQ(set->modules.size(), 7u);
}

// ---- accepted input ---------------------------------------------------------------------------

TEST(ModuleXml, NameTagOverridesTheStem) {
    SetSpec set = accepted(document(periodic("cntr1").set("name", "first"), periodic("cntr1").set("name", "second")));
    ASSERT_EQ(set.modules.size(), 2u);
    EXPECT_EQ(set.modules[0].name, "first");
    EXPECT_EQ(set.modules[1].name, "second");
    EXPECT_EQ(set.modules[0].filename, "./cntr1.so");
}

TEST(ModuleXml, NameIsTheStemOfTheLastComponent) {
    SetSpec set = accepted(document(periodic().set("filename", "../lib/libio.dispatch.so")));
    ASSERT_EQ(set.modules.size(), 1u);
    EXPECT_EQ(set.modules[0].name, "libio.dispatch");
}

TEST(ModuleXml, RelativeFilenamesResolveAgainstTheXmlFolder) {
    SetSpec set = accepted(document(periodic().set("filename", "./a/../b/./x.so").set("name", "x"),
                                    periodic().set("filename", "../lib/y.so").set("name", "y"),
                                    periodic().set("filename", "/opt/z/./z.so").set("name", "z")));
    ASSERT_EQ(set.modules.size(), 3u);
    EXPECT_EQ(set.modules[0].path, fs::path("/sets/bad/b/x.so"));
    EXPECT_EQ(set.modules[1].path, fs::path("/sets/lib/y.so"));
    EXPECT_EQ(set.modules[2].path, fs::path("/opt/z/z.so"));  // absolute stays, normalised
    EXPECT_EQ(set.modules[0].filename, "./a/../b/./x.so");    // as written
}

TEST(ModuleXml, RelativeXmlPathIsAnchoredAtTheWorkingDirectory) {
    SetSpec set = accepted(document(periodic("cntr1")), "sets/demo/module.xml");
    ASSERT_EQ(set.modules.size(), 1u);
    EXPECT_EQ(set.modules[0].path, (fs::current_path() / "sets/demo/cntr1.so").lexically_normal());
    EXPECT_EQ(set.modules[0].where, "sets/demo/module.xml:3");  // messages show the path as given
}

TEST(ModuleXml, PredefinedEntitiesAndCharacterReferencesAreDecoded) {
    SetSpec set =
        accepted(document(periodic().line("<property><value name=\"a&amp;b\">&lt;x&gt; &amp; &apos;y&apos; "
                                          "&quot;z&quot; &#65;&#x42; &#xE9; &#x20AC;</value>"
                                          "<value name=\"cdata\"><![CDATA[&lt; stays]]></value></property>")));
    ASSERT_EQ(set.modules.size(), 1u);
    using Props = std::vector<std::pair<std::string, std::string>>;
    EXPECT_EQ(set.modules[0].properties,
              (Props{{"a&b", "<x> & 'y' \"z\" AB \xC3\xA9 \xE2\x82\xAC"}, {"cdata", "&lt; stays"}}));
}

TEST(ModuleXml, EntitiesAreDecodedInLeafFields) {
    SetSpec set = accepted(document(periodic().set("period", "&#49;00000").set("name", "a&#45;b")));
    ASSERT_EQ(set.modules.size(), 1u);
    EXPECT_EQ(set.modules[0].period_ns, 100000);
    EXPECT_EQ(set.modules[0].name, "a-b");
}

TEST(ModuleXml, WhitespaceAroundValuesIsIgnored) {
    SetSpec set = accepted(document(periodic().set("period", "\n      100000\n    ").set("moduletype", " thread ")));
    ASSERT_EQ(set.modules.size(), 1u);
    EXPECT_EQ(set.modules[0].period_ns, 100000);
}

TEST(ModuleXml, PeriodicDeadlineIsOptionalAndMayEqualThePeriod) {
    SetSpec set = accepted(
        document(periodic("a"), periodic("b").set("deadline", "100000"), periodic("c").set("deadline", "50000")));
    ASSERT_EQ(set.modules.size(), 3u);
    EXPECT_EQ(set.modules[0].deadline_ns, 0);
    EXPECT_EQ(set.modules[1].deadline_ns, 100000);
    EXPECT_EQ(set.modules[2].deadline_ns, 50000);
}

TEST(ModuleXml, NonRealModuleNeedsNoPriority) {
    SetSpec set = accepted(document(nonReal()));
    ASSERT_EQ(set.modules.size(), 1u);
    EXPECT_EQ(set.modules[0].operation, OperationType::NonReal);
    EXPECT_EQ(set.modules[0].type, ModuleType::Process);
}

TEST(ModuleXml, ExecutorsAndBudgets) {
    const std::string executor = "  <executor><name>io</name><rtpriority>80</rtpriority><cpu>2</cpu></executor>\n";
    SetSpec set = accepted(document(executor, periodic("a").set("executor", "io").set("budget", "100000"),
                                    periodic("b").set("executor", "main")));
    ASSERT_EQ(set.executors.size(), 1u);
    EXPECT_EQ(set.executors[0].name, "io");
    EXPECT_EQ(set.executors[0].rt_priority, 80);
    EXPECT_EQ(set.executors[0].cpu, 2);
    EXPECT_EQ(set.executors[0].line, 3);
    ASSERT_EQ(set.modules.size(), 2u);
    EXPECT_EQ(set.modules[0].executor, "io");
    EXPECT_EQ(set.modules[0].budget_ns, 100000);
    EXPECT_EQ(set.modules[1].executor, "main");
}

TEST(ModuleXml, WritesDeclaresTheVariablesAModuleWrites) {
    SetSpec set = accepted(document(
        periodic("a").line("<writes>knu.Robot.tick</writes>").line("<writes> joint[1].y </writes>"), periodic("b")));
    ASSERT_EQ(set.modules.size(), 2u);
    EXPECT_EQ(set.modules[0].writes, (std::vector<std::string>{"knu.Robot.tick", "joint[1].y"}));
    EXPECT_TRUE(set.modules[1].writes.empty());
}

TEST(ModuleXml, OverrunWatchdogTagsAndTheirDefaults) {
    Module process = periodic("p");
    process.set("moduletype", "process").set("filename", "./p.exe").set("on_overrun", "restart");
    SetSpec set = accepted(document(periodic("a").set("on_overrun", "stop").set("overrun_limit", "300000"),
                                    periodic("b").set("on_overrun", "skip"),
                                    periodic("c").set("deadline", "50000").set("on_overrun", "warn"),
                                    periodic("d").set("on_overrun", "disable"), process, periodic("none")));
    ASSERT_EQ(set.modules.size(), 6u);
    EXPECT_EQ(set.modules[0].on_overrun, irp::config::OverrunAction::Stop);
    EXPECT_EQ(set.modules[0].overrun_limit_ns, 300000);  // may exceed the period
    EXPECT_EQ(set.modules[1].on_overrun, irp::config::OverrunAction::Skip);
    EXPECT_EQ(set.modules[1].overrun_limit_ns, 100000);  // default: the period
    EXPECT_EQ(set.modules[2].overrun_limit_ns, 50000);   // ... or the deadline
    EXPECT_EQ(set.modules[3].on_overrun, irp::config::OverrunAction::Disable);
    EXPECT_EQ(set.modules[4].on_overrun, irp::config::OverrunAction::Restart);
    EXPECT_EQ(set.modules[5].on_overrun, irp::config::OverrunAction::None);  // the paper's files: no watchdog
    EXPECT_EQ(set.modules[5].overrun_limit_ns, 0);
}

TEST(ModuleXml, OnCrashDefaultsToExclude) {
    SetSpec set = accepted(
        document(periodic("a"), periodic("b").set("on_crash", "restart"), periodic("c").set("on_crash", "exclude")));
    EXPECT_EQ(set.modules[0].on_crash, irp::config::CrashPolicy::Exclude);
    EXPECT_EQ(set.modules[1].on_crash, irp::config::CrashPolicy::Restart);
    EXPECT_EQ(set.modules[2].on_crash, irp::config::CrashPolicy::Exclude);
}

TEST(ModuleXml, CarriageReturnLineEndingsCountLinesTheSame) {
    std::string text = document(periodic("a"), periodic("b").set("period", "0"));
    const int line = lineOf(text, "<period>0<");
    std::string crlf;
    for (char c : text) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
    EXPECT_TRUE(refusedAt(crlf, line, {"module 'b'", "<period>"}));
}

// ---- refused input: one test per malformed input ----------------------------------------------

TEST(ModuleXmlBad, UnknownTagInModule) {
    const std::string text = document(periodic().line("<perod>100000</perod>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<perod>"),
                          {"module 'cntr1': unknown tag <perod> in <module>", "expected one of filename, moduletype"}));
}

TEST(ModuleXmlBad, TextAfterRootIsRefused) {
    const std::string text = document(periodic()) + "stray words\n";
    EXPECT_TRUE(refusedAt(text, lineOf(text, "stray words"), {"unexpected text 'stray words'"}));
}

TEST(ModuleXmlBad, ProcessingInstructionIsRefused) {
    const std::string text = document(periodic(), "  <?php echo 1; ?>\n");
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<?php"), {"processing instruction <?php?> is not allowed"}));
}

TEST(ModuleXmlBad, UnknownTagInRoot) {
    const std::string text = document(periodic(), "  <modul></modul>\n");
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<modul>"), {"unknown tag <modul> in <root>", "expected <module>"}));
}

TEST(ModuleXmlBad, WrongRootElement) {
    const std::string text = "<?xml version=\"1.0\"?>\n\n<modules>\n" + periodic().xml() + "</modules>\n";
    EXPECT_TRUE(refusedAt(text, 3, {"<modules>", "expected <root>"}));
}

TEST(ModuleXmlBad, SecondTopLevelElement) {
    const std::string text = document(periodic()) + "<root>\n</root>\n";
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<root>", 1), {"second top-level element <root>"}));
}

TEST(ModuleXmlBad, UnknownModuleType) {
    const std::string text = document(periodic().set("moduletype", "dll"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<moduletype>"),
                          {"module 'cntr1'", "<moduletype>", "'dll'", "expected thread or process"}));
}

TEST(ModuleXmlBad, ModuleTypeIsCaseSensitive) {
    const std::string text = document(periodic().set("moduletype", "Thread"));
    EXPECT_TRUE(
        refusedAt(text, lineOf(text, "<moduletype>"), {"<moduletype>", "'Thread'", "expected thread or process"}));
}

TEST(ModuleXmlBad, MissingModuleType) {
    const std::string text = document(periodic().without("moduletype"));
    EXPECT_TRUE(
        refusedAt(text, lineOf(text, "<module>"), {"module 'cntr1'", "<moduletype> is missing", "thread or process"}));
}

TEST(ModuleXmlBad, UnknownOperationType) {
    const std::string text = document(periodic().set("operationtype", "cyclic"));
    EXPECT_TRUE(
        refusedAt(text, lineOf(text, "<operationtype>"),
                  {"module 'cntr1'", "<operationtype>", "'cyclic'", "expected periodic, sporadic or non-real"}));
}

TEST(ModuleXmlBad, NonRealSpelledWithoutHyphen) {
    const std::string text = document(nonReal().set("operationtype", "nonreal"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<operationtype>"), {"<operationtype>", "'nonreal'", "non-real"}));
}

TEST(ModuleXmlBad, MissingOperationType) {
    const std::string text = document(periodic().without("operationtype"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<module>"),
                          {"module 'cntr1'", "<operationtype> is missing", "periodic, sporadic or non-real"}));
}

TEST(ModuleXmlBad, PeriodicWithoutPeriod) {
    const std::string text = document(periodic("ok"), periodic("cntr2").without("period"));
    EXPECT_TRUE(
        refusedAt(text, lineOf(text, "<module>", 1), {"module 'cntr2'", "<period> is missing", "periodic", "ns"}));
}

TEST(ModuleXmlBad, PeriodZero) {
    const std::string text = document(periodic().set("period", "0"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<period>"), {"module 'cntr1'", "<period>", "'0'", "greater than 0"}));
}

TEST(ModuleXmlBad, PeriodNegative) {
    const std::string text = document(periodic().set("period", "-100000"));
    EXPECT_TRUE(
        refusedAt(text, lineOf(text, "<period>"), {"module 'cntr1'", "<period>", "'-100000'", "greater than 0"}));
}

TEST(ModuleXmlBad, PeriodInScientificNotation) {
    const std::string text = document(periodic().set("period", "1e5"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<period>"),
                          {"module 'cntr1'", "<period>", "'1e5' is not an integer", "number of nanoseconds"}));
}

TEST(ModuleXmlBad, PeriodWithUnit) {
    const std::string text = document(periodic().set("period", "100us"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<period>"), {"<period>", "'100us' is not an integer", "nanoseconds"}));
}

TEST(ModuleXmlBad, PeriodNotANumber) {
    const std::string text = document(periodic().set("period", "abc"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<period>"), {"<period>", "'abc' is not an integer", "nanoseconds"}));
}

TEST(ModuleXmlBad, PeriodEmpty) {
    const std::string text = document(periodic().set("period", ""));
    EXPECT_TRUE(
        refusedAt(text, lineOf(text, "<period>"), {"module 'cntr1'", "<period>", "empty", "expected an integer"}));
}

TEST(ModuleXmlBad, PeriodWithDecimalPoint) {
    const std::string text = document(periodic().set("period", "100000.0"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<period>"), {"<period>", "'100000.0' is not an integer"}));
}

TEST(ModuleXmlBad, PeriodWithPlusSign) {
    const std::string text = document(periodic().set("period", "+100000"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<period>"), {"<period>", "'+100000' is not an integer"}));
}

TEST(ModuleXmlBad, PeriodOverflow) {
    const std::string text = document(periodic().set("period", "9223372036854775808"));  // 2^63
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<period>"),
                          {"module 'cntr1'", "<period>", "'9223372036854775808'", "too large"}));
}

TEST(ModuleXmlBad, DeadlineLongerThanPeriod) {
    const std::string text = document(periodic().set("deadline", "100001"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<deadline>"),
                          {"module 'cntr1'", "<deadline>", "100001", "longer than the period 100000"}));
}

TEST(ModuleXmlBad, DeadlineZero) {
    const std::string text = document(sporadic().set("deadline", "0"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<deadline>"), {"module 'event1'", "<deadline>", "greater than 0"}));
}

TEST(ModuleXmlBad, SporadicWithoutDeadline) {
    const std::string text = document(sporadic().without("deadline"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<module>"), {"module 'event1'", "<deadline> is missing", "sporadic"}));
}

TEST(ModuleXmlBad, SporadicWithPeriod) {
    const std::string text = document(sporadic().set("period", "100000"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<period>"), {"module 'event1'", "<period>", "sporadic", "<deadline>"}));
}

TEST(ModuleXmlBad, NonRealWithPeriod) {
    const std::string text = document(nonReal().set("period", "100000"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<period>"), {"module 'logger'", "<period>", "non-real", "no <period>"}));
}

TEST(ModuleXmlBad, NonRealWithDeadline) {
    const std::string text = document(nonReal().set("deadline", "100000"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<deadline>"), {"module 'logger'", "<deadline>", "no <deadline>"}));
}

TEST(ModuleXmlBad, PeriodicWithoutPriority) {
    const std::string text = document(periodic().without("priority"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<module>"),
                          {"module 'cntr1'", "<priority> is missing", "lowest value is the highest priority"}));
}

TEST(ModuleXmlBad, SporadicWithoutPriority) {
    const std::string text = document(sporadic().without("priority"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<module>"), {"module 'event1'", "<priority> is missing"}));
}

TEST(ModuleXmlBad, NegativePriority) {
    const std::string text = document(periodic().set("priority", "-1"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<priority>"), {"module 'cntr1'", "<priority>", "'-1'", "at least 0"}));
}

TEST(ModuleXmlBad, PriorityNotAnInteger) {
    const std::string text = document(periodic().set("priority", "high"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<priority>"), {"<priority>", "'high' is not an integer"}));
}

TEST(ModuleXmlBad, PriorityTooLarge) {
    const std::string text = document(periodic().set("priority", "1000001"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<priority>"), {"module 'cntr1'", "<priority>", "above 1000000"}));
}

TEST(ModuleXmlBad, DuplicateNamesFromStems) {
    // Same stem in two folders: the second is refused, naming the line of the first.
    const std::string text =
        document(periodic().set("filename", "./a/cntr1.so"), periodic().set("filename", "./b/cntr1.so"));
    const int first = lineOf(text, "<module>", 0), second = lineOf(text, "<module>", 1);
    const std::string also = "also the module at line " + std::to_string(first);
    EXPECT_TRUE(refusedAt(text, second, {"module 'cntr1'", "duplicate name", also, "set <name>"}));
}

TEST(ModuleXmlBad, DuplicateNamesFromNameTags) {
    const std::string text =
        document(periodic("a").set("name", "ctl"), periodic("b"), periodic("c").set("name", "ctl"));
    const int first = lineOf(text, "<module>", 0), third = lineOf(text, "<module>", 2);
    const std::string also = "also the module at line " + std::to_string(first);
    EXPECT_TRUE(refusedAt(text, third, {"module 'ctl'", "duplicate name", also}));
}

TEST(ModuleXmlBad, DuplicateNameStemAgainstNameTag) {
    const std::string text = document(periodic("cntr1"), periodic("other").set("name", "cntr1"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<module>", 1),
                          {"module 'cntr1'", "duplicate name", "also the module at line 3"}));
}

TEST(ModuleXmlBad, TagRepeatedInOneModule) {
    const std::string text = document(periodic().line("<period>200000</period>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<period>", 1), {"<period> appears twice in one <module>"}));
}

TEST(ModuleXmlBad, PropertyRepeatedInOneModule) {
    const std::string text =
        document(periodic().line("<property><value name=\"a\">1</value></property>").line("<property></property>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<property>", 1), {"<property> appears twice"}));
}

TEST(ModuleXmlBad, MissingFilename) {
    const std::string text = document(periodic().without("filename"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<module>"), {"<module> without <filename>"}));
}

TEST(ModuleXmlBad, EmptyFilename) {
    const std::string text = document(periodic().set("filename", "  "));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<filename>"), {"<filename>", "is empty"}));
}

TEST(ModuleXmlBad, FilenameWithoutStem) {
    const std::string text = document(periodic().set("filename", "./build/"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<filename>"), {"module name is empty"}));
}

TEST(ModuleXmlBad, MalformedUnclosedTag) {
    const std::string text = "<?xml version=\"1.0\"?>\n<root>\n  <module>\n    <period>100000\n  </module>\n</root>\n";
    auto parsed = parseModuleXmlText(text, kFakePath);
    ASSERT_FALSE(parsed.ok());
    // pugixml notices at </module>, the first end tag that does not match.
    EXPECT_TRUE(refusedAt(text, 5, {"malformed XML"}));
}

TEST(ModuleXmlBad, MalformedDocumentEndsInsideAnElement) {
    const std::string text =
        document(periodic()).substr(0, document(periodic()).size() - std::string("</root>\n").size());
    auto parsed = parseModuleXmlText(text, kFakePath);
    ASSERT_FALSE(parsed.ok());
    EXPECT_NE(parsed.error().message.find("malformed XML"), std::string::npos) << parsed.error().message;
    EXPECT_EQ(parsed.error().message.rfind(kFakePath + ":", 0), 0u) << parsed.error().message;
}

TEST(ModuleXmlBad, MalformedMismatchedTag) {
    const std::string text = document(periodic().line("<priority>1</priorty>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "</priorty>"), {"malformed XML", "mismatch"}));
}

TEST(ModuleXmlBad, MalformedAttributeWithoutQuotes) {
    const std::string text = document(periodic().line("<property><value name=a>1</value></property>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "name=a"), {"malformed XML"}));
}

TEST(ModuleXmlBad, EmptyDocument) { EXPECT_TRUE(refusedAt("", 1, {"no <root> element"})); }

TEST(ModuleXmlBad, DoctypeWithEntitiesIsRefused) {
    // "billion laughs": refused before anything is expanded.
    const std::string text = "<?xml version=\"1.0\"?>\n"
                             "<!DOCTYPE root [\n"
                             "  <!ENTITY lol \"lol\">\n"
                             "  <!ENTITY lol1 \"&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;\">\n"
                             "  <!ENTITY lol2 \"&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;\">\n"
                             "  <!ENTITY lol3 \"&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;\">\n"
                             "]>\n"
                             "<root>\n" +
                             periodic().line("<property><value name=\"x\">&lol3;</value></property>").xml() +
                             "</root>\n";
    EXPECT_TRUE(refusedAt(text, 2, {"DOCTYPE is not allowed", "entity"}));
}

TEST(ModuleXmlBad, DoctypeWithoutSubsetIsRefused) {
    const std::string text = "<?xml version=\"1.0\"?>\n<!DOCTYPE root SYSTEM \"file:///etc/passwd\">\n<root>\n" +
                             periodic().xml() + "</root>\n";
    EXPECT_TRUE(refusedAt(text, 2, {"DOCTYPE is not allowed"}));
}

TEST(ModuleXmlBad, UndefinedEntityInPropertyValue) {
    const std::string text = document(periodic().line("<property><value name=\"x\">&foo;</value></property>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "&foo;"), {"entity reference '&foo;' is not allowed", "&amp;"}));
}

TEST(ModuleXmlBad, UndefinedEntityInLeafField) {
    const std::string text = document(periodic().set("period", "&period;"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "&period;"), {"'&period;' is not allowed"}));
}

TEST(ModuleXmlBad, UndefinedEntityInAttribute) {
    const std::string text = document(periodic().line("<property><value name=\"&foo;\">1</value></property>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "&foo;"), {"'&foo;' is not allowed"}));
}

TEST(ModuleXmlBad, BareAmpersand) {
    const std::string text = document(periodic().line("<property><value name=\"x\">a & b</value></property>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "a & b"), {"bare '&'", "&amp;"}));
}

TEST(ModuleXmlBad, BadCharacterReference) {
    const std::string text = document(periodic().line("<property><value name=\"x\">&#0;</value></property>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "&#0;"), {"bad character reference '&#0;'"}));
}

TEST(ModuleXmlBad, CharacterReferenceBeyondUnicode) {
    const std::string text = document(periodic().line("<property><value name=\"x\">&#x110000;</value></property>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "&#x110000;"), {"bad character reference"}));
}

TEST(ModuleXmlBad, CharacterReferenceToASurrogate) {
    // Not a character: decoding it would put invalid UTF-8 into the property.
    const std::string text = document(periodic().line("<property><value name=\"x\">&#xD800;</value></property>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "&#xD800;"), {"bad character reference '&#xD800;'"}));
}

TEST(ModuleXmlBad, UndefinedEntityOnALaterLineOfAValue) {
    // The line is that of the reference, not that of the <value> it sits in.
    const std::string text = document(
        periodic().line("<property><value name=\"x\">").line("first line").line("&foo;").line("</value></property>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "&foo;"), {"'&foo;' is not allowed"}));
}

TEST(ModuleXmlBad, UnknownAttributeOnModule) {
    Module m = periodic();
    m.open = "<module type=\"fast\">";
    const std::string text = document(m);
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<module "), {"unknown attribute 'type' on <module>"}));
}

TEST(ModuleXmlBad, UnknownAttributeOnLeafField) {
    const std::string text = document(periodic().without("period").line("<period unit=\"us\">100</period>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<period "), {"unknown attribute 'unit' on <period>"}));
}

TEST(ModuleXmlBad, UnknownAttributeOnRoot) {
    const std::string text = "<?xml version=\"1.0\"?>\n<root version=\"2\">\n" + periodic().xml() + "</root>\n";
    EXPECT_TRUE(refusedAt(text, 2, {"unknown attribute 'version' on <root>"}));
}

TEST(ModuleXmlBad, UnknownAttributeOnPropertyValue) {
    const std::string text = document(periodic().line("<property><value name=\"x\" type=\"int\">1</value></property>"));
    EXPECT_TRUE(
        refusedAt(text, lineOf(text, "<value"), {"module 'cntr1'", "unknown attribute 'type' on <value>", "name="}));
}

TEST(ModuleXmlBad, DuplicateAttributeOnPropertyValue) {
    const std::string text = document(periodic().line("<property><value name=\"x\" name=\"y\">1</value></property>"));
    auto parsed = parseModuleXmlText(text, kFakePath);
    ASSERT_FALSE(parsed.ok()) << "a second name= would silently win";
    EXPECT_TRUE(
        refusedAt(text, lineOf(text, "<value"), {"module 'cntr1'", "name=\"...\" appears twice on one <value>"}));
}

TEST(ModuleXmlBad, PropertyValueWithoutName) {
    const std::string text = document(periodic().line("<property>").line("<value>5</value>").line("</property>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<value>"), {"module 'cntr1'", "<value> without a name=\"...\""}));
}

TEST(ModuleXmlBad, PropertyValueWithEmptyName) {
    const std::string text = document(periodic().line("<property><value name=\"\">5</value></property>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<value"), {"module 'cntr1'", "<value> without a name"}));
}

TEST(ModuleXmlBad, DuplicatePropertyName) {
    const std::string text = document(periodic()
                                          .line("<property>")
                                          .line("  <value name=\"gain\">1</value>")
                                          .line("  <value name=\"gain\">2</value>")
                                          .line("</property>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<value", 1), {"module 'cntr1'", "property 'gain' is set twice"}));
}

TEST(ModuleXmlBad, UnknownTagInProperty) {
    const std::string text = document(periodic().line("<property><item name=\"x\">1</item></property>"));
    EXPECT_TRUE(
        refusedAt(text, lineOf(text, "<item"), {"module 'cntr1'", "unknown tag <item> in <property>", "<value name="}));
}

TEST(ModuleXmlBad, PropertyValueWithElementInside) {
    const std::string text = document(periodic().line("<property><value name=\"x\"><b/></value></property>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<b/>"), {"property 'x' must be plain text"}));
}

TEST(ModuleXmlBad, ElementInsideLeafField) {
    const std::string text = document(periodic().set("period", "<ns>100000</ns>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<period>"), {"<period>", "expected plain text, found <ns>"}));
}

TEST(ModuleXmlBad, InvalidModuleNameFromStem) {
    const std::string text = document(periodic().set("filename", "./my module.so"));
    EXPECT_TRUE(
        refusedAt(text, lineOf(text, "<filename>"), {"module name 'my module'", "letters, digits", "set <name>"}));
}

TEST(ModuleXmlBad, InvalidModuleNameTag) {
    const std::string text = document(periodic().set("name", "a/b"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<name>"), {"module name 'a/b'", "letters, digits"}));
}

TEST(ModuleXmlBad, EmptyNameTag) {
    const std::string text = document(periodic().set("name", ""));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<name>"), {"<name>", "is empty"}));
}

TEST(ModuleXmlBad, ModuleNameTooLong) {
    const std::string text = document(periodic().set("name", std::string(64, 'x')));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<name>"), {"longer than 63 characters"}));
}

TEST(ModuleXmlBad, ExecutorNotDefined) {
    const std::string text = document(periodic().set("executor", "io"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<executor>"),
                          {"module 'cntr1'", "<executor>", "no <executor> named 'io' is defined"}));
}

TEST(ModuleXmlBad, ExecutorReferenceEmpty) {
    const std::string text = document(periodic().set("executor", ""));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<executor>"), {"module 'cntr1'", "<executor>", "is empty"}));
}

TEST(ModuleXmlBad, ExecutorWithoutName) {
    const std::string text = document("  <executor><cpu>1</cpu></executor>\n", periodic());
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<executor>"), {"<executor> without a <name>"}));
}

TEST(ModuleXmlBad, ExecutorNamedMain) {
    const std::string text = document("  <executor><name>main</name></executor>\n", periodic());
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<executor>"), {"'main' is reserved"}));
}

TEST(ModuleXmlBad, ExecutorDefinedTwice) {
    const std::string text =
        document("  <executor><name>io</name></executor>\n", "  <executor><name>io</name></executor>\n", periodic());
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<executor>", 1), {"executor 'io' is defined twice"}));
}

TEST(ModuleXmlBad, ExecutorRtPriorityZero) {
    const std::string text =
        document("  <executor><name>io</name>\n<rtpriority>0</rtpriority></executor>\n", periodic());
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<rtpriority>"), {"executor 'io': <rtpriority>", "greater than 0"}));
}

TEST(ModuleXmlBad, ExecutorRtPriorityAbove99) {
    const std::string text =
        document("  <executor><name>io</name>\n<rtpriority>100</rtpriority></executor>\n", periodic());
    EXPECT_TRUE(
        refusedAt(text, lineOf(text, "<rtpriority>"), {"executor 'io': <rtpriority>: '100' must be from 1 to 99"}));
}

TEST(ModuleXmlBad, ExecutorCpuNegative) {
    const std::string text = document("  <executor><name>io</name>\n<cpu>-1</cpu></executor>\n", periodic());
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<cpu>"), {"<cpu>", "'-1'", "at least 0"}));
}

TEST(ModuleXmlBad, ExecutorUnknownTag) {
    const std::string text = document("  <executor><name>io</name>\n<core>1</core></executor>\n", periodic());
    EXPECT_TRUE(
        refusedAt(text, lineOf(text, "<core>"), {"unknown tag <core> in <executor>", "name, rtpriority or cpu"}));
}

TEST(ModuleXmlBad, ExecutorInvalidName) {
    const std::string text = document("  <executor><name>i o</name></executor>\n", periodic());
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<executor>"), {"name 'i o'"}));
}

TEST(ModuleXmlBad, BudgetLongerThanPeriod) {
    const std::string text = document(periodic().set("budget", "100001"));
    EXPECT_TRUE(
        refusedAt(text, lineOf(text, "<budget>"), {"module 'cntr1'", "<budget>", "longer than the period 100000"}));
}

TEST(ModuleXmlBad, WritesEmptyOrTwice) {
    const std::string empty = document(periodic().line("<writes> </writes>"));
    EXPECT_TRUE(refusedAt(empty, lineOf(empty, "<writes>"), {"module 'cntr1'", "<writes>", "is empty"}));
    const std::string twice = document(periodic().line("<writes>a.b</writes>").line("<writes>a.b</writes>"));
    EXPECT_TRUE(refusedAt(twice, lineOf(twice, "<writes>a.b</writes>", 1), {"'a.b' is declared twice"}));
}

TEST(ModuleXmlBad, OnCrashUnknownValue) {
    const std::string text = document(periodic().set("on_crash", "sometimes"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<on_crash>"),
                          {"module 'cntr1'", "<on_crash>", "'sometimes'; expected exclude or restart"}));
}

TEST(ModuleXmlBad, BudgetOnSporadicModule) {
    const std::string text = document(sporadic().set("budget", "1000"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<budget>"), {"module 'event1'", "<budget>", "only periodic"}));
}

TEST(ModuleXmlBad, OnOverrunUnknownValue) {
    const std::string text = document(periodic().set("on_overrun", "reboot"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<on_overrun>"),
                          {"module 'cntr1'", "<on_overrun>", "'reboot'", "warn, skip, disable or stop"}));
}

TEST(ModuleXmlBad, OnOverrunRestartOnAThread) {
    const std::string text = document(periodic().set("on_overrun", "restart"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<on_overrun>"), {"'restart'", "for a thread module"}));
}

TEST(ModuleXmlBad, OnOverrunSkipOnAProcess) {
    const std::string text = document(periodic().set("moduletype", "process").set("on_overrun", "skip"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<on_overrun>"), {"'skip'", "warn, restart or stop", "process module"}));
}

TEST(ModuleXmlBad, OnOverrunOnSporadicModule) {
    const std::string text = document(sporadic().set("on_overrun", "warn"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<on_overrun>"), {"module 'event1'", "only periodic"}));
}

TEST(ModuleXmlBad, OverrunLimitWithoutOnOverrun) {
    const std::string text = document(periodic().set("overrun_limit", "100000"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<overrun_limit>"), {"<overrun_limit>", "needs an <on_overrun>"}));
}

TEST(ModuleXmlBad, OverrunLimitNotAPositiveInteger) {
    for (const char *bad : {"0", "-5", "1ms"}) {
        const std::string text = document(periodic().set("on_overrun", "warn").set("overrun_limit", bad));
        EXPECT_TRUE(refusedAt(text, lineOf(text, "<overrun_limit>"), {"<overrun_limit>", bad})) << bad;
    }
}

TEST(ModuleXmlBad, TextBetweenElementsInModule) {
    const std::string text = document(periodic().line("oops"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "oops"), {"unexpected text 'oops' between elements"}));
}

TEST(ModuleXmlBad, TextBetweenElementsInRoot) {
    const std::string text = document(periodic(), "  stray\n");
    EXPECT_TRUE(refusedAt(text, lineOf(text, "stray"), {"unexpected text 'stray'"}));
}

TEST(ModuleXmlBad, TextBetweenPropertyValues) {
    const std::string text = document(periodic().line("<property>").line("gain=1").line("</property>"));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "gain=1"), {"unexpected text 'gain=1'"}));
}

TEST(ModuleXmlBad, FileNotFound) {
    const fs::path missing = kFixtures / "no-such-dir" / "module.xml";
    auto parsed = parseModuleXml(missing);
    ASSERT_FALSE(parsed.ok());
    EXPECT_EQ(parsed.error().message, missing.string() + ": no such file (the set's module.xml)");
}

TEST(ModuleXmlBad, DirectoryInsteadOfFile) {
    auto parsed = parseModuleXml(kFixtures);
    ASSERT_FALSE(parsed.ok());
    EXPECT_EQ(parsed.error().message.rfind(kFixtures.string() + ": ", 0), 0u) << parsed.error().message;
}

TEST(ModuleXmlBad, OversizedFile) {
    ScratchDir dir;
    const fs::path xml = dir.path() / "module.xml";
    {
        // A valid document padded with a comment to just above the limit: refused by size alone.
        std::ofstream out(xml, std::ios::binary);
        out << document(periodic()) << "<!--" << std::string(irp::config::kMaxXmlBytes, ' ') << "-->\n";
    }
    auto parsed = parseModuleXml(xml);
    ASSERT_FALSE(parsed.ok());
    EXPECT_EQ(parsed.error().message, xml.string() + ": larger than 4 MiB; not a module.xml");
}

TEST(ModuleXmlBad, OversizedText) {
    const std::string text = document(periodic()) + "<!--" + std::string(irp::config::kMaxXmlBytes, ' ') + "-->\n";
    auto parsed = parseModuleXmlText(text, kFakePath);
    ASSERT_FALSE(parsed.ok());
    EXPECT_EQ(parsed.error().message, kFakePath + ": larger than 4 MiB; not a module.xml");
}

TEST(ModuleXmlBad, JustBelowTheSizeLimitIsRead) {
    ScratchDir dir;
    const fs::path xml = dir.path() / "module.xml";
    const std::string head = document(periodic());
    {
        std::ofstream out(xml, std::ios::binary);
        out << head << "<!--" << std::string(irp::config::kMaxXmlBytes - head.size() - 8, ' ') << "-->\n";
    }
    ASSERT_LE(fs::file_size(xml), irp::config::kMaxXmlBytes);
    auto parsed = parseModuleXml(xml);
    ASSERT_TRUE(parsed.ok()) << parsed.error().message;
    EXPECT_EQ(parsed->modules.size(), 1u);
    EXPECT_EQ(parsed->modules[0].path, dir.path() / "cntr1.so");
}

TEST(ModuleXmlBad, ErrorsInARealFileNameThatFile) {
    ScratchDir dir;
    const fs::path xml = dir.path() / "module.xml";
    const std::string text = document(periodic().set("period", "0"));
    std::ofstream(xml, std::ios::binary) << text;
    auto parsed = parseModuleXml(xml);
    ASSERT_FALSE(parsed.ok());
    EXPECT_EQ(parsed.error().message.rfind(xml.string() + ":" + std::to_string(lineOf(text, "<period>")) + ": ", 0), 0u)
        << parsed.error().message;
}

TEST(ModuleXmlBad, TooManyModules) {
    std::string modules;
    for (std::size_t i = 0; i <= irp::config::kMaxModules; ++i) modules += periodic("m" + std::to_string(i)).xml();
    const std::string text = document(modules);
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<filename>./m1024.so<") - 1, {"more than 1024 modules"}));
}

// ---- the place as fields: file, line, column, module, field -----------------------------------

// The refusal of text, which must be refused.
static irp::Error refusal(const std::string &text) {
    auto parsed = parseModuleXmlText(text, kFakePath);
    EXPECT_FALSE(parsed.ok()) << text;
    return parsed.ok() ? irp::Error{} : parsed.error();
}

// 1-based column of needle in its line of text.
static int columnOf(const std::string &text, std::string_view needle) {
    const std::size_t at = text.find(needle);
    const std::size_t newline = text.rfind('\n', at);
    return static_cast<int>(at - (newline == std::string::npos ? 0 : newline + 1)) + 1;
}

TEST(ModuleXmlPlace, AFieldsRefusalNamesTheModuleTheFieldAndTheColumn) {
    const std::string text = document(periodic("a"), periodic("b").set("period", "0"));
    const irp::Error e = refusal(text);
    EXPECT_EQ(e.code, "refused");
    EXPECT_EQ(e.place.file, kFakePath);
    EXPECT_EQ(e.place.line, lineOf(text, "<period>0<"));
    EXPECT_EQ(e.place.column, columnOf(text, "<period>0<"));
    EXPECT_EQ(e.place.module, "b");
    EXPECT_EQ(e.place.field, "period");
}

TEST(ModuleXmlPlace, AProcessPropertyIsTheFieldPropertyDotItsName) {
    const std::string text =
        document(nonReal("p").line("<property><value name=\"restart\">sometimes</value></property>"));
    const irp::Error e = refusal(text);
    EXPECT_NE(e.message.find("restart"), std::string::npos) << e.message;
    EXPECT_EQ(e.place.line, lineOf(text, "sometimes"));
    EXPECT_EQ(e.place.module, "p");
    EXPECT_EQ(e.place.field, "property.restart");
}

TEST(ModuleXmlPlace, AnExecutorsFieldNamesTheExecutor) {
    const std::string text =
        document("  <executor><name>io</name>\n    <rtpriority>120</rtpriority></executor>\n", periodic());
    const irp::Error e = refusal(text);
    EXPECT_EQ(e.place.line, lineOf(text, "<rtpriority>"));
    EXPECT_EQ(e.place.column, columnOf(text, "<rtpriority>"));
    EXPECT_EQ(e.place.module, "io");
    EXPECT_EQ(e.place.field, "rtpriority");
}

TEST(ModuleXmlPlace, AWholeSetCheckNamesTheModuleAtItsLine) {
    const std::string text = document(periodic("a"), periodic("a", "200000"));
    const irp::Error e = refusal(text);
    EXPECT_EQ(e.place.line, lineOf(text, "<module>", 1));
    EXPECT_EQ(e.place.module, "a");
    EXPECT_EQ(e.place.field, "");
}

TEST(ModuleXmlPlace, MalformedXmlHasNoModuleAndARootTagNoField) {
    const irp::Error broken = refusal("<root>\n  <module>\n</root>\n");
    EXPECT_EQ(broken.place.file, kFakePath);
    EXPECT_GT(broken.place.line, 0);
    EXPECT_EQ(broken.place.module, "");
    const std::string text = document(periodic("a"), "  <layout></layout>\n");
    const irp::Error layout = refusal(text);
    EXPECT_EQ(layout.place.line, lineOf(text, "<layout>"));
    EXPECT_EQ(layout.place.module, "") << "a module read before does not follow into the root's tags";
    EXPECT_EQ(layout.place.field, "");
}
