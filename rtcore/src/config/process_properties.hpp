// process_properties.hpp -- the properties of a process module (module.xml <property><value
// name=...>), parsed and checked when module.xml is read, so that `check`, a dry run and
// `irpctl validate` refuse a bad one as the start would (docs/process-modules.md).
//
//   args              command-line arguments: split on white space, "..." quotes one argument
//                     (\" and \\ inside quotes);
//   env.NAME          the environment variable NAME (INDUROP_* set by irpd are refused);
//   restart           never | always | on-failure (default): when an exit is followed by a new
//                     start.  A failure is a signal or a non-zero status; status 78 (a process
//                     built against another shared-variable layout) is never restarted;
//   restart_delay_ms  the first restart's delay, 1..10000 (default 100); doubled for each
//                     consecutive failure up to 10 s, back to the first after 10 s of running;
//   max_restarts      how many restarts at most, a number or "unlimited" (default); 0 = none.
//
// Other names are not process properties and are left alone (thread modules get every property
// in their initialize()).
#pragma once

#include <indurop/result.hpp>

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace irp::config {

enum class RestartPolicy { Never, Always, OnFailure };
const char *toString(RestartPolicy policy);

inline constexpr int64_t kDefaultRestartDelayNs = 100'000'000;
inline constexpr int64_t kMaxRestartDelayNs = 10'000'000'000;  // also the backoff's cap
inline constexpr int64_t kMaxRestartsLimit = 1'000'000'000;

struct ProcessProperties {
    std::vector<std::string> args;                         // after argv[0]
    std::vector<std::pair<std::string, std::string>> env;  // NAME, value
    RestartPolicy restart = RestartPolicy::OnFailure;
    int64_t restart_delay_ns = kDefaultRestartDelayNs;
    int64_t max_restarts = -1;  // -1 = unlimited

    bool operator==(const ProcessProperties &) const = default;
};

// The variables irpd sets for every process module (env.* may not override them).
bool isIrpdVariable(std::string_view name);

// Applies one property to `into`.  A bad value is an Error naming the property, the value and
// what is accepted ("property restart = 'sometimes': expected never, always or on-failure"),
// without a place: the caller adds file:line and the module.  A name that is no process
// property is Ok and changes nothing.
Status applyProcessProperty(ProcessProperties &into, const std::string &name, const std::string &value);

// Every property of a module in order (for a ModuleSpec built in code); the first bad one's Error.
Result<ProcessProperties> parseProcessProperties(const std::vector<std::pair<std::string, std::string>> &properties);

// The `args` property split into arguments: white space separates, "..." groups (\" and \\ inside).
Result<std::vector<std::string>> splitArgs(const std::string &text);

}  // namespace irp::config
