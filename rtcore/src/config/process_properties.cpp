// process_properties.cpp -- parses and checks the properties of a process module (args, env.NAME,
// restart, restart_delay_ms, max_restarts); see process_properties.hpp.
#include "config/process_properties.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <iterator>
#include <utility>

namespace irp::config {
namespace {

constexpr int64_t kMs = 1'000'000;

// A whole number within [low, high] written in plain digits.
Result<int64_t> parseCount(const std::string &name, const std::string &text, int64_t low, int64_t high,
                           const char *besides = "") {
    int64_t value = 0;
    const char *end = text.data() + text.size();
    const bool digits = !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
    auto [p, ec] = std::from_chars(text.data(), end, value);
    if (!digits || ec != std::errc() || p != end || value < low || value > high)
        return Error{"property " + name + " = '" + text + "': expected a whole number from " + std::to_string(low) +
                     " to " + std::to_string(high) + besides};
    return value;
}

}  // namespace

// Each policy and its name in module.xml.
constexpr std::pair<RestartPolicy, const char *> kRestartPolicies[] = {
    {RestartPolicy::Never, "never"}, {RestartPolicy::Always, "always"}, {RestartPolicy::OnFailure, "on-failure"}};

const char *toString(RestartPolicy policy) {
    for (const auto &[p, name] : kRestartPolicies)
        if (p == policy) return name;
    return "?";
}

bool isIrpdVariable(std::string_view name) {
    return name == "INDUROP_CTL" || name == "INDUROP_SLOT" || name == "INDUROP_SHM" || name == "INDUROP_MODULE" ||
           name == "INDUROP_ALARMS" || name == "INDUROP_ALARM_SOURCE";
}

Result<std::vector<std::string>> splitArgs(const std::string &text) {
    std::vector<std::string> args;
    std::size_t i = 0;
    while (i < text.size()) {
        while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
        if (i == text.size()) break;
        std::string arg;
        while (i < text.size() && !std::isspace(static_cast<unsigned char>(text[i]))) {
            if (text[i] != '"') {
                arg += text[i++];
                continue;
            }
            const std::size_t open = i++;
            for (;;) {
                if (i == text.size())
                    return Error{"unterminated \" at character " + std::to_string(open + 1) + " of '" + text + "'"};
                if (text[i] == '"') {
                    ++i;
                    break;
                }
                if (text[i] == '\\' && i + 1 < text.size() && (text[i + 1] == '"' || text[i + 1] == '\\')) ++i;
                arg += text[i++];
            }
        }
        args.push_back(std::move(arg));
    }
    return args;
}

Status applyProcessProperty(ProcessProperties &into, const std::string &name, const std::string &value) {
    if (name == "args") {
        auto args = splitArgs(value);
        if (!args) return Error{"property args: " + args.error().message + "; close the quote or write it as \\\""};
        into.args = std::move(*args);
    } else if (name.starts_with("env.")) {
        const std::string var = name.substr(4);
        if (var.empty() || var.find('=') != std::string::npos)
            return Error{"property " + name + ": '" + var +
                         "' is not an environment variable name (env.NAME, NAME not "
                         "empty and without '=')"};
        if (isIrpdVariable(var))
            return Error{"property " + name + ": " + var + " is set by irpd and cannot be overridden"};
        into.env.emplace_back(var, value);
    } else if (name == "restart") {
        auto known = std::find_if(std::begin(kRestartPolicies), std::end(kRestartPolicies),
                                  [&](const auto &entry) { return value == entry.second; });
        if (known == std::end(kRestartPolicies))
            return Error{"property restart = '" + value + "': expected never, always or on-failure"};
        into.restart = known->first;
    } else if (name == "restart_delay_ms") {
        auto ms = parseCount(name, value, 1, kMaxRestartDelayNs / kMs, " (milliseconds)");
        if (!ms) return ms.error();
        into.restart_delay_ns = *ms * kMs;
    } else if (name == "max_restarts") {
        if (value == "unlimited") {
            into.max_restarts = -1;
        } else {
            auto n = parseCount(name, value, 0, kMaxRestartsLimit, ", or unlimited");
            if (!n) return n.error();
            into.max_restarts = *n;
        }
    }
    return Ok{};
}

Result<ProcessProperties> parseProcessProperties(const std::vector<std::pair<std::string, std::string>> &properties) {
    ProcessProperties parsed;
    for (const auto &[name, value] : properties)
        if (Status st = applyProcessProperty(parsed, name, value); !st) return st.error();
    return parsed;
}

}  // namespace irp::config
