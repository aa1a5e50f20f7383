// test_module_xml_alarms.cpp -- module.xml's <alarm id="N" severity="...">text</alarm>
// (docs/alarms.md, docs/module-xml.md): what is accepted, and one named test per malformed
// declaration, each refusal naming file:line, the module, what was expected, with its place's
// module and field (alarm.<id> once the id is known).
#include "config/module_xml.hpp"
#include "protocol/limits.hpp"
#include "support/module_xml_text.hpp"

#include <gtest/gtest.h>

#include <string>

using irp::Severity;
using irp::config::AlarmSpec;
using namespace module_xml_text;

namespace {

// Module "plc" with the given <alarm> lines.
Module withAlarms(std::initializer_list<std::string> lines) {
    Module m = periodic("plc");
    for (const std::string &l : lines) m.line(l);
    return m;
}

// The refusal's module and field, as the control protocol sends them.
void expectPlace(const std::string &text, const std::string &module, const std::string &field) {
    auto parsed = parseModuleXmlText(text, kFakePath);
    ASSERT_FALSE(parsed.ok()) << text;
    EXPECT_EQ(parsed.error().place.module, module) << parsed.error().message;
    EXPECT_EQ(parsed.error().place.field, field) << parsed.error().message;
}

}  // namespace

TEST(ModuleXmlAlarms, DeclarationsAreReadInFileOrderWithTheirSeverity) {
    const std::string text = document(withAlarms({
        R"(<alarm id="8" severity="high">drive communication lost</alarm>)",
        R"(<alarm id="1" severity="low">not powered</alarm>)",
        R"(<alarm id="1023" severity="critical">last id</alarm>)",
    }));
    const SetSpec set = accepted(text);
    const ModuleSpec *m = find(set, "plc");
    ASSERT_NE(m, nullptr);
    ASSERT_EQ(m->alarms.size(), 3u);
    EXPECT_EQ(m->alarms[0].id, 8u);
    EXPECT_EQ(m->alarms[0].severity, Severity::High);
    EXPECT_EQ(m->alarms[0].text, "drive communication lost");
    EXPECT_EQ(m->alarms[0].line, lineOf(text, "id=\"8\""));
    EXPECT_EQ(m->alarms[1].severity, Severity::Low);
    EXPECT_EQ(m->alarms[2].id, 1023u);
    EXPECT_EQ(m->alarms[2].severity, Severity::Critical);
}

TEST(ModuleXmlAlarms, TheSeverityIsMediumUnlessGiven) {
    const SetSpec set = accepted(document(withAlarms({R"(<alarm id="3">unreachable</alarm>)"})));
    ASSERT_EQ(find(set, "plc")->alarms.size(), 1u);
    EXPECT_EQ(find(set, "plc")->alarms[0].severity, Severity::Medium);
}

TEST(ModuleXmlAlarms, ATextOverLinesBecomesOneLineAndEscapesAreDecoded) {
    const SetSpec set = accepted(document(withAlarms({"<alarm id=\"4\">\n      drive fault:\n\t  axis &lt;n&gt; &amp; "
                                                      "<![CDATA[<brake>]]>   </alarm>"})));
    EXPECT_EQ(find(set, "plc")->alarms[0].text, "drive fault: axis <n> & <brake>");
}

TEST(ModuleXmlAlarms, AProcessModuleDeclaresToo) {
    Module p = nonReal("logger");
    p.line(R"(<alarm id="2" severity="high">disk full</alarm>)");
    EXPECT_EQ(find(accepted(document(p)), "logger")->alarms[0].text, "disk full");
}

TEST(ModuleXmlAlarms, TheTextMayHoldAlarmTextMaxCharactersCountedAsCharacters) {
    std::string text;
    for (int i = 0; i < irp::protocol::kAlarmTextMax; ++i) text += "\xC3\xA9";  // é: two bytes, one character
    const SetSpec set = accepted(document(withAlarms({"<alarm id=\"5\">" + text + "</alarm>"})));
    EXPECT_EQ(find(set, "plc")->alarms[0].text, text);
}

// ---- refusals ---------------------------------------------------------------------------------

TEST(ModuleXmlAlarms, AnIdOfZeroIsRefused) {
    const std::string text = document(withAlarms({R"(<alarm id="0">x</alarm>)"}));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<alarm"), {"module 'plc'", "<alarm>", "id '0'", "from 1 to 1023"}));
    expectPlace(text, "plc", "alarm");
}

TEST(ModuleXmlAlarms, AnIdOver1023IsRefused) {
    const std::string text = document(withAlarms({R"(<alarm id="1024">x</alarm>)"}));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<alarm"), {"id '1024'", "from 1 to 1023"}));
}

TEST(ModuleXmlAlarms, AnIdThatIsNoNumberIsRefused) {
    const std::string text = document(withAlarms({R"(<alarm id="eight">x</alarm>)"}));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<alarm"), {"id 'eight'", "integer"}));
}

TEST(ModuleXmlAlarms, AMissingIdIsRefused) {
    const std::string text = document(withAlarms({R"(<alarm severity="low">x</alarm>)"}));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<alarm"), {"module 'plc'", "id=\"...\" is missing"}));
    expectPlace(text, "plc", "alarm");
}

TEST(ModuleXmlAlarms, AnIdDeclaredTwiceInOneModuleIsRefusedNamingTheFirst) {
    const std::string text =
        document(withAlarms({R"(<alarm id="8">comm lost</alarm>)", R"(<alarm id="8">communication lost</alarm>)"}));
    const int first = lineOf(text, "<alarm"), second = lineOf(text, "<alarm", 1);
    EXPECT_TRUE(refusedAt(text, second,
                          {"<alarm id=\"8\">", "declared twice", "also at line " + std::to_string(first), "unique"}));
    expectPlace(text, "plc", "alarm.8");
}

TEST(ModuleXmlAlarms, TheSameIdInTwoModulesIsFine) {
    Module other = periodic("robot");
    other.line(R"(<alarm id="8">comm lost</alarm>)");
    const SetSpec set = accepted(document(withAlarms({R"(<alarm id="8">comm lost</alarm>)"}), other));
    EXPECT_EQ(set.modules.size(), 2u);
}

TEST(ModuleXmlAlarms, AnUnknownSeverityIsRefused) {
    const std::string text = document(withAlarms({R"(<alarm id="2" severity="urgent">x</alarm>)"}));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<alarm"),
                          {"<alarm id=\"2\">", "severity 'urgent'", "low, medium, high or critical"}));
    expectPlace(text, "plc", "alarm.2");
}

TEST(ModuleXmlAlarms, AnEmptyTextIsRefused) {
    const std::string text = document(withAlarms({R"(<alarm id="2">   </alarm>)"}));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<alarm"), {"<alarm id=\"2\">", "the text is empty"}));
}

TEST(ModuleXmlAlarms, ATextOverAlarmTextMaxCharactersIsRefused) {
    const std::string long_text(static_cast<std::size_t>(irp::protocol::kAlarmTextMax) + 1, 'x');
    const std::string text = document(withAlarms({"<alarm id=\"2\">" + long_text + "</alarm>"}));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<alarm"),
                          {"has " + std::to_string(long_text.size()) + " characters",
                           "at most " + std::to_string(irp::protocol::kAlarmTextMax)}));
}

TEST(ModuleXmlAlarms, AControlCharacterInTheTextIsRefused) {
    const std::string text = document(withAlarms({R"(<alarm id="2">bell&#7;here</alarm>)"}));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<alarm"), {"control character"}));
}

TEST(ModuleXmlAlarms, AnElementInsideTheTextIsRefused) {
    const std::string text = document(withAlarms({R"(<alarm id="2">see <b>here</b></alarm>)"}));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<alarm"), {"expected the alarm's text, found <b>"}));
}

TEST(ModuleXmlAlarms, AnUnknownAttributeIsRefused) {
    const std::string text = document(withAlarms({R"(<alarm id="2" text="x">x</alarm>)"}));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<alarm"), {"unknown attribute 'text'", "id=", "severity="}));
}

TEST(ModuleXmlAlarms, AnAttributeGivenTwiceIsRefused) {
    const std::string text = document(withAlarms({R"(<alarm id="2" id="3">x</alarm>)"}));
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<alarm"), {"module 'plc'", "id=\"...\" appears twice"}));
}

TEST(ModuleXmlAlarms, AnAlarmOutsideAModuleIsRefused) {
    const std::string text = document(periodic("plc"), std::string(R"(  <alarm id="2">x</alarm>)") + "\n");
    EXPECT_TRUE(refusedAt(text, lineOf(text, "<alarm"), {"unknown tag <alarm> in <root>"}));
}

TEST(ModuleXmlAlarms, AModuleWhoseAlarmsChangedIsNotTheSameForASwap) {
    const SetSpec a = accepted(document(withAlarms({R"(<alarm id="8">comm lost</alarm>)"})));
    const SetSpec b = accepted(document(withAlarms({R"(<alarm id="8">communication lost</alarm>)"})));
    const SetSpec c = accepted(document(withAlarms({"<alarm id=\"8\">\n comm lost</alarm>"})));
    EXPECT_FALSE(irp::config::sameAlarms(a.modules[0], b.modules[0]));
    EXPECT_TRUE(irp::config::sameAlarms(a.modules[0], c.modules[0]));  // another line, the same declaration
}
