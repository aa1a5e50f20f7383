// fuzz_control.cpp -- libFuzzer target: arbitrary bytes as one request line on irpd's control
// socket (docs/control-protocol.md), through the code the control thread runs for it without a
// running set: control::answerRequest (JSON, the "cmd" check, the answer line) and
// daemon::decodeCommand (every command's arguments); a decoded `write` goes on to
// variables::writeByPath against the plc-robot layout on a real shared-variable segment.
// The answer must be one JSON object line with a boolean "ok"; anything else is a finding.
#include "control/control_server.hpp"
#include "irpd/commands.hpp"
#include "variables/variable_write.hpp"

#include "fuzz_segment.hpp"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace {

using json = nlohmann::ordered_json;

[[noreturn]] void finding(const char *what, const std::string &answer) {
    std::fprintf(stderr, "fuzz_control: %s: %s\n", what, answer.c_str());
    std::abort();
}

nlohmann::json layoutJson;

irp::Result<json> handle(const std::string &cmd, const nlohmann::json &request) {
    auto command = irp::daemon::decodeCommand(cmd, request);
    if (!command) return command.error();
    using Kind = irp::daemon::Command::Kind;
    if (command->kind == Kind::Write) return irp::variables::writeByPath(layoutJson, command->path, command->value);
    json changes = json::array();
    for (const irp::reload::Change &c : command->changes) {
        changes.push_back({{"module", c.module},
                           {"period_ns", c.period_ns ? json(*c.period_ns) : json(nullptr)},
                           {"priority", c.priority ? json(*c.priority) : json(nullptr)},
                           {"enabled", c.enabled ? json(*c.enabled) : json(nullptr)}});
    }
    return json{{"kind", static_cast<int>(command->kind)},
                {"name", command->name},
                {"since", command->since},
                {"limit", command->limit},
                {"config", command->config},
                {"set_id", command->set_id},
                {"changes", std::move(changes)},
                {"dry_run", command->dry_run}};
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int *, char ***) {
    layoutJson = nlohmann::json::parse(fuzz::plcRobotSegment("fuzz-control").text);
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    // The control thread hands over what is before a '\n', at most kMaxRequestBytes.
    std::string request(reinterpret_cast<const char *>(data), size);
    if (request.find('\n') != std::string::npos || request.size() > irp::control::kMaxRequestBytes) return -1;
    const std::string answer = irp::control::answerRequest(request, handle);
    if (answer.empty() || answer.back() != '\n' || answer.find('\n') != answer.size() - 1)
        finding("not one line", answer);
    json parsed;
    try {
        parsed = json::parse(answer);
    } catch (const std::exception &e) {
        finding("the answer is not JSON", answer);
    }
    if (!parsed.is_object() || !parsed.contains("ok") || !parsed["ok"].is_boolean())
        finding("no boolean \"ok\"", answer);
    if (!parsed["ok"].get<bool>() && parsed["error"].value("message", "").empty())
        finding("a refusal without a message", answer);
    return 0;
}
