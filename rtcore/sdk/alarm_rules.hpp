// alarm_rules.hpp -- what an alarm declaration must be, written once for module.xml's <alarm>
// (config/module_xml.cpp) and irp::declareAlarm (sdk/alarms.cpp): ids, texts, severity names
// (docs/alarms.md).  Not installed.
#pragma once

#include "protocol/limits.hpp"

#include <indurop/alarms.h>
#include <indurop/indurop.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace irp::alarm_rules {

inline constexpr auto kTextMax = static_cast<std::size_t>(protocol::kAlarmTextMax);  // characters

// Characters (UTF-8 code points) of a text.
inline std::size_t characters(std::string_view text) {
    std::size_t n = 0;
    for (char c : text) n += (static_cast<unsigned char>(c) & 0xC0) != 0x80;
    return n;
}

// "" when `text` may be an alarm's declared text: 1 .. kTextMax characters, one line (no control
// character); else what is wrong with it.
inline std::string textProblem(std::string_view text) {
    if (text.empty()) return "the text is empty; say what the operator should know";
    if (characters(text) > kTextMax)
        return "the text has " + std::to_string(characters(text)) + " characters; at most " + std::to_string(kTextMax) +
               " are allowed";
    for (char c : text)
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7F)
            return "the text holds a control character (a newline, a tab...); write it on one line";
    return {};
}

inline bool validId(uint64_t id) { return id >= 1 && id <= INDUROP_ALARM_ID_MAX; }

inline const char *severityName(Severity s) {
    switch (s) {
    case Severity::Low: return "low";
    case Severity::Medium: return "medium";
    case Severity::High: return "high";
    case Severity::Critical: return "critical";
    default: return "declared";
    }
}

// low, medium, high, critical; nothing else.
inline std::optional<Severity> severityNamed(std::string_view name) {
    for (Severity s : {Severity::Low, Severity::Medium, Severity::High, Severity::Critical})
        if (name == severityName(s)) return s;
    return std::nullopt;
}

}  // namespace irp::alarm_rules
