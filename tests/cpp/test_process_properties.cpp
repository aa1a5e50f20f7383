// test_process_properties.cpp -- a process module's properties (args, env.NAME, restart,
// restart_delay_ms, max_restarts) are parsed when module.xml is read: accepted values land in
// ModuleSpec::process, and every bad one is refused by the parser -- so by `check`, dry runs and
// `irpctl validate` too -- naming file:line of its <value>, the module, the property and what is
// accepted.  One named test per malformed property, built from the shared fragments.
#include "config/module_xml.hpp"
#include "config/process_properties.hpp"
#include "support/module_xml_text.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

using irp::config::parseProcessProperties;
using irp::config::ProcessProperties;
using irp::config::RestartPolicy;
using irp::config::splitArgs;
using namespace module_xml_text;

namespace {

// A non-real process module "logger" with one <property> holding `values`, one <value> per line.
std::string processWith(const std::vector<std::pair<std::string, std::string>> &values) {
    Module m = nonReal();
    m.line("<property>");
    for (const auto &[name, value] : values) m.line("  <value name=\"" + name + "\">" + value + "</value>");
    m.line("</property>");
    return document(m);
}

// Refused at the line of the <value> named `property`, with these pieces.
::testing::AssertionResult refusesProperty(const std::string &property, const std::string &value,
                                           std::initializer_list<std::string_view> pieces) {
    const std::string text = processWith({{"journal", "/tmp/log"}, {property, value}});
    return refusedAt(text, lineOf(text, "name=\"" + property + "\""), pieces);
}

}  // namespace

// ---- accepted ---------------------------------------------------------------------------------

TEST(ProcessProperties, ParsedIntoTheModuleSpecWhenModuleXmlIsRead) {
    const SetSpec set = accepted(processWith({{"args", R"(--port 15020 "two words" "q\"uote")"},
                                              {"env.FOO", "bar baz"},
                                              {"restart", "always"},
                                              {"restart_delay_ms", "250"},
                                              {"max_restarts", "3"},
                                              {"journal", "/tmp/not-a-process-property"}}));
    ASSERT_EQ(set.modules.size(), 1u);
    const ProcessProperties &p = set.modules[0].process;
    EXPECT_EQ(p.args, (std::vector<std::string>{"--port", "15020", "two words", "q\"uote"}));
    EXPECT_EQ(p.env, (std::vector<std::pair<std::string, std::string>>{{"FOO", "bar baz"}}));
    EXPECT_EQ(p.restart, RestartPolicy::Always);
    EXPECT_EQ(p.restart_delay_ns, 250'000'000);
    EXPECT_EQ(p.max_restarts, 3);
    EXPECT_EQ(set.modules[0].properties.size(), 6u);  // the raw list stays as written
}

TEST(ProcessProperties, DefaultsWithoutAnyProperty) {
    const SetSpec set = accepted(document(nonReal()));
    ASSERT_EQ(set.modules.size(), 1u);
    EXPECT_EQ(set.modules[0].process, ProcessProperties{});
    EXPECT_EQ(set.modules[0].process.restart, RestartPolicy::OnFailure);
    EXPECT_EQ(set.modules[0].process.restart_delay_ns, 100'000'000);
    EXPECT_EQ(set.modules[0].process.max_restarts, -1);
}

TEST(ProcessProperties, EveryAcceptedValueOfTheLimits) {
    for (const char *policy : {"never", "always", "on-failure"})
        EXPECT_EQ(toString(accepted(processWith({{"restart", policy}})).modules[0].process.restart),
                  std::string(policy));
    EXPECT_EQ(accepted(processWith({{"restart_delay_ms", "1"}})).modules[0].process.restart_delay_ns, 1'000'000);
    EXPECT_EQ(accepted(processWith({{"restart_delay_ms", "10000"}})).modules[0].process.restart_delay_ns,
              10'000'000'000);
    EXPECT_EQ(accepted(processWith({{"max_restarts", "0"}})).modules[0].process.max_restarts, 0);
    EXPECT_EQ(accepted(processWith({{"max_restarts", "unlimited"}})).modules[0].process.max_restarts, -1);
    EXPECT_TRUE(accepted(processWith({{"args", ""}})).modules[0].process.args.empty());
}

TEST(ProcessProperties, AThreadModuleKeepsWhatANameMeansToIt) {
    // Thread modules get every property in initialize(): "restart" is theirs to interpret.
    const SetSpec set =
        accepted(document(periodic().line(R"(<property><value name="restart">sometimes</value></property>)")));
    ASSERT_EQ(set.modules.size(), 1u);
    EXPECT_EQ(set.modules[0].properties, (std::vector<std::pair<std::string, std::string>>{{"restart", "sometimes"}}));
    EXPECT_EQ(set.modules[0].process, ProcessProperties{});
}

TEST(ProcessProperties, APeriodicProcessIsCheckedToo) {
    Module m = periodic("drive", "1000000");
    m.set("moduletype", "process").line(R"(<property><value name="restart">sometimes</value></property>)");
    const std::string text = document(m);
    EXPECT_TRUE(refusedAt(text, lineOf(text, "name=\"restart\""), {"module 'drive': property restart = 'sometimes'"}));
}

// ---- refused, one test per bad property --------------------------------------------------------

TEST(ProcessPropertiesBad, RestartSometimes) {
    EXPECT_TRUE(
        refusesProperty("restart", "sometimes",
                        {"module 'logger': property restart = 'sometimes': expected never, always or on-failure"}));
}

TEST(ProcessPropertiesBad, RestartIsCaseSensitive) {
    EXPECT_TRUE(refusesProperty("restart", "Always", {"property restart = 'Always'", "never, always or on-failure"}));
}

TEST(ProcessPropertiesBad, RestartEmpty) {
    EXPECT_TRUE(refusesProperty("restart", "", {"property restart = ''", "never, always or on-failure"}));
}

TEST(ProcessPropertiesBad, RestartDelayNotANumber) {
    EXPECT_TRUE(refusesProperty(
        "restart_delay_ms", "soon",
        {"module 'logger': property restart_delay_ms = 'soon': expected a whole number from 1 to 10000"}));
}

TEST(ProcessPropertiesBad, RestartDelayZero) {
    EXPECT_TRUE(refusesProperty("restart_delay_ms", "0", {"restart_delay_ms = '0'", "from 1 to 10000"}));
}

TEST(ProcessPropertiesBad, RestartDelayAboveTenSeconds) {
    EXPECT_TRUE(refusesProperty("restart_delay_ms", "10001", {"restart_delay_ms = '10001'", "from 1 to 10000"}));
}

TEST(ProcessPropertiesBad, RestartDelayWithUnit) {
    EXPECT_TRUE(refusesProperty("restart_delay_ms", "100ms", {"restart_delay_ms = '100ms'", "(milliseconds)"}));
}

TEST(ProcessPropertiesBad, RestartDelayOverflow) {
    EXPECT_TRUE(refusesProperty("restart_delay_ms", "99999999999999999999999",
                                {"restart_delay_ms = '9999", "from 1 to 10000"}));
}

TEST(ProcessPropertiesBad, MaxRestartsNegative) {
    EXPECT_TRUE(refusesProperty("max_restarts", "-1",
                                {"module 'logger': property max_restarts = '-1': expected a whole number from 0 to "
                                 "1000000000, or unlimited"}));
}

TEST(ProcessPropertiesBad, MaxRestartsWord) {
    EXPECT_TRUE(refusesProperty("max_restarts", "many", {"max_restarts = 'many'", "or unlimited"}));
}

TEST(ProcessPropertiesBad, ArgsWithAnUnterminatedQuote) {
    EXPECT_TRUE(refusesProperty("args", "a \"b c", {"module 'logger': property args: unterminated \" at character 3"}));
}

TEST(ProcessPropertiesBad, EnvOverridingAnIrpdVariable) {
    EXPECT_TRUE(
        refusesProperty("env.INDUROP_SLOT", "0",
                        {"module 'logger': property env.INDUROP_SLOT: INDUROP_SLOT is set by irpd and cannot be "
                         "overridden"}));
}

TEST(ProcessPropertiesBad, EnvWithoutAName) {
    EXPECT_TRUE(refusesProperty("env.", "x", {"property env.: '' is not an environment variable name"}));
}

TEST(ProcessPropertiesBad, EnvNameWithAnEqualsSign) {
    EXPECT_TRUE(refusesProperty("env.A=B", "x", {"property env.A=B: 'A=B' is not an environment variable name"}));
}

// ---- the parts, for modules made in code ------------------------------------------------------

TEST(ProcessPropertiesParts, TheFirstBadPropertyIsTheError) {
    auto parsed = parseProcessProperties({{"restart", "never"}, {"max_restarts", "x"}, {"restart", "sometimes"}});
    ASSERT_FALSE(parsed.ok());
    EXPECT_EQ(parsed.error().message,
              "property max_restarts = 'x': expected a whole number from 0 to 1000000000, or unlimited");
    auto good = parseProcessProperties({{"restart", "never"}, {"args", "-v"}});
    ASSERT_TRUE(good.ok()) << good.error().message;
    EXPECT_EQ(good->restart, RestartPolicy::Never);
    EXPECT_EQ(good->args, std::vector<std::string>{"-v"});
}

TEST(ProcessPropertiesParts, SplitArgsQuotesAndEscapes) {
    EXPECT_EQ(splitArgs("  a  b\tc ").value(), (std::vector<std::string>{"a", "b", "c"}));
    EXPECT_EQ(splitArgs(R"(x"y z"w)").value(), (std::vector<std::string>{"xy zw"}));
    EXPECT_EQ(splitArgs(R"("a\"b" "c\\d" "e\f")").value(), (std::vector<std::string>{"a\"b", "c\\d", "e\\f"}));
    EXPECT_EQ(splitArgs(R"("")").value(), (std::vector<std::string>{""}));
    EXPECT_TRUE(splitArgs("").value().empty());
    EXPECT_FALSE(splitArgs("\"open").ok());
}
