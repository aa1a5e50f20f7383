// module_xml_text.hpp -- module.xml documents built from shared fragments for the parser's tests
// (one named test per malformed input, ros2_control's test_component_parser style), and the check
// that a refusal is one line naming file:line and every expected piece, with the same file and line
// as the fields of its place.
#pragma once

#include "config/module_xml.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <initializer_list>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace module_xml_text {

using irp::config::ModuleSpec;
using irp::config::parseModuleXmlText;
using irp::config::SetSpec;

// ---- shared fragments ------------------------------------------------------------------------

// The name bad documents are parsed under: never read, only shown in messages and used as the
// anchor of relative filenames.
inline const std::string kFakePath = "/sets/bad/module.xml";

// One <module> as a list of leaf fields, one per line, plus raw lines appended after them.
struct Module {
    std::vector<std::pair<std::string, std::string>> fields;  // tag, inner XML
    std::vector<std::string> raw;

    Module &set(const std::string &tag, const std::string &value) {
        for (auto &[t, v] : fields)
            if (t == tag) {
                v = value;
                return *this;
            }
        fields.emplace_back(tag, value);
        return *this;
    }
    Module &without(const std::string &tag) {
        std::erase_if(fields, [&](const auto &f) { return f.first == tag; });
        return *this;
    }
    Module &line(const std::string &xml) {
        raw.push_back(xml);
        return *this;
    }
    std::string open = "<module>";

    std::string xml() const {
        std::string out = "  " + open + "\n";
        for (const auto &[tag, value] : fields) out += "    <" + tag + ">" + value + "</" + tag + ">\n";
        for (const std::string &r : raw) out += "    " + r + "\n";
        return out + "  </module>\n";
    }
};

inline Module periodic(const std::string &stem = "cntr1", const std::string &period = "100000",
                       const std::string &priority = "1") {
    Module m;
    m.set("filename", "./" + stem + ".so")
        .set("moduletype", "thread")
        .set("operationtype", "periodic")
        .set("period", period)
        .set("priority", priority);
    return m;
}

inline Module sporadic(const std::string &stem = "event1", const std::string &deadline = "1000000") {
    Module m;
    m.set("filename", "./" + stem + ".so")
        .set("moduletype", "thread")
        .set("operationtype", "sporadic")
        .set("deadline", deadline)
        .set("priority", "1");
    return m;
}

inline Module nonReal(const std::string &stem = "logger") {
    Module m;
    m.set("filename", "./" + stem + ".exe").set("moduletype", "process").set("operationtype", "non-real");
    return m;
}

inline std::string xmlOf(const Module &m) { return m.xml(); }
inline std::string xmlOf(const std::string &raw) { return raw; }

// A whole document: the declaration on line 1, <root> on line 2, then the parts, then </root>.
template <class... Parts>
inline std::string document(const Parts &...parts) {
    return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<root>\n" + (std::string() + ... + xmlOf(parts)) + "</root>\n";
}

// 1-based line of the n-th (0-based) occurrence of needle in text; 0 when absent.
inline int lineOf(const std::string &text, std::string_view needle, int nth = 0) {
    std::size_t at = text.find(needle);
    for (int i = 0; i < nth && at != std::string::npos; ++i) at = text.find(needle, at + 1);
    if (at == std::string::npos) return 0;
    return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

// The text must be refused with one line that starts with "<path>:<line>: " and holds every piece.
inline ::testing::AssertionResult refusedAt(const std::string &text, int line,
                                            std::initializer_list<std::string_view> pieces,
                                            const std::string &path = kFakePath) {
    if (line <= 0) return ::testing::AssertionFailure() << "bad test: the expected line is " << line;
    auto parsed = parseModuleXmlText(text, path);
    if (parsed.ok())
        return ::testing::AssertionFailure() << "accepted, with " << parsed->modules.size() << " modules:\n" << text;
    const std::string &message = parsed.error().message;
    const std::string prefix = path + ":" + std::to_string(line) + ": ";
    if (message.find('\n') != std::string::npos)
        return ::testing::AssertionFailure() << "the message is not one line: " << message;
    if (message.rfind(prefix, 0) != 0)
        return ::testing::AssertionFailure() << "the message does not start with '" << prefix << "': " << message;
    for (std::string_view piece : pieces)
        if (message.find(piece) == std::string::npos)
            return ::testing::AssertionFailure() << "the message lacks '" << piece << "': " << message;
    // The place is also given as fields, the same as the message's.
    const irp::Place &place = parsed.error().place;
    if (place.file != path || place.line != line)
        return ::testing::AssertionFailure()
               << "the place's fields say " << place.file << ":" << place.line << ", the message " << prefix;
    return ::testing::AssertionSuccess() << message;
}

// Parses text that must be accepted.
inline SetSpec accepted(const std::string &text, const std::string &path = kFakePath) {
    auto parsed = parseModuleXmlText(text, path);
    EXPECT_TRUE(parsed.ok()) << parsed.error().message << "\n" << text;
    return parsed.ok() ? std::move(parsed).value() : SetSpec{};
}

inline const ModuleSpec *find(const SetSpec &set, const std::string &name) {
    for (const ModuleSpec &m : set.modules)
        if (m.name == name) return &m;
    return nullptr;
}

}  // namespace module_xml_text
