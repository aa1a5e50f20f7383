// module_xml.hpp -- module.xml, the paper's set description (Figures 1 and 9), parsed and validated.
//
// parseModuleXml() turns the file into a SetSpec or one Error naming file:line, the module and the
// field.  It checks everything that can be checked without touching the modules' files; loading
// them (and so "missing file") is the hosts' job.  The format and its extensions are in
// docs/module-xml.md.
#pragma once

#include <indurop/result.hpp>
#include "config/process_properties.hpp"
#include "protocol/limits.hpp"

#include <indurop/indurop.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace irp::config {

enum class ModuleType { Thread, Process };
enum class OperationType { Periodic, Sporadic, NonReal };
// <on_overrun>: what the watchdog does with a run longer than <overrun_limit> (docs/faults.md).
// None = no watchdog (a file without the tag runs as before).
enum class OverrunAction : uint8_t { None, Warn, Skip, Disable, Stop, Restart };
// <on_crash>: after irpd died of a crash in this thread module, does the restart run it again?
enum class CrashPolicy { Exclude, Restart };

const char *toString(ModuleType type);
const char *toString(OperationType type);
const char *toString(OverrunAction action);

// The executor every module runs on unless it names another one.
inline constexpr const char *kMainExecutor = "main";

// <alarm id="8" severity="high">drive communication lost</alarm> in a <module> (docs/alarms.md).
struct AlarmSpec {
    uint32_t id = 0;                       // 1 .. INDUROP_ALARM_ID_MAX, unique per module
    Severity severity = Severity::Medium;  // low, medium (the default), high, critical
    std::string text;                      // one line: the element's whitespace collapsed
    int line = 0;
};

struct ModuleSpec {
    std::string name;            // <name>, or the stem of <filename>
    std::string filename;        // as written in the XML
    std::filesystem::path path;  // resolved against the XML file's folder
    std::string set_dir;         // that folder, absolute: thread modules get it as property indurop.set_dir
    ModuleType type = ModuleType::Thread;
    OperationType operation = OperationType::Periodic;
    int64_t period_ns = 0;    // periodic only
    int64_t deadline_ns = 0;  // sporadic: required; periodic: optional (0 = the period)
    int priority = 0;         // lowest value = highest priority
    int64_t budget_ns = 0;    // optional execution budget; 0 = none
    std::string executor = kMainExecutor;
    OverrunAction on_overrun = OverrunAction::None;  // <on_overrun>
    int64_t overrun_limit_ns = 0;  // <overrun_limit>: the watchdog time; 0 with on_overrun = the deadline
    CrashPolicy on_crash = CrashPolicy::Exclude;                  // <on_crash>
    std::vector<std::pair<std::string, std::string>> properties;  // <property><value name=..>
    // A process module's args, env.*, restart, restart_delay_ms and max_restarts, parsed from
    // `properties` when module.xml is read (a ModuleSpec made in code: parseProcessProperties).
    ProcessProperties process;
    std::vector<AlarmSpec> alarms;    // <alarm>s, in file order
    std::vector<std::string> writes;  // <writes>: the shared variables it declares it writes (docs/dds.md)
    int index = 0;                    // position in the file (ties in priority go to the earlier one)
    int line = 0;                     // line of <module>
    std::string where;                // "path/module.xml:12", for messages
    std::string xml;                  // that module.xml, absolute: the file of an error's place
};

// The same <alarm>s (ids, severities, texts, in order; not their lines).
inline bool sameAlarms(const ModuleSpec &a, const ModuleSpec &b) {
    return std::equal(a.alarms.begin(), a.alarms.end(), b.alarms.begin(), b.alarms.end(),
                      [](const AlarmSpec &x, const AlarmSpec &y) {
                          return x.id == y.id && x.severity == y.severity && x.text == y.text;
                      });
}

// An extra dispatcher thread (<executor> at the root): its own RT priority and CPU.
struct ExecutorSpec {
    std::string name;
    int rt_priority = 0;  // 0 = the main executor's priority minus one
    int cpu = -1;         // -1 = the main executor's CPU
    int line = 0;
};

// An error about module m, at its <module> line: "<where>: module 'm': what", placed there (its
// module.xml and line, the module, and `field` when it is about one of the module's elements).
Error errorAbout(const ModuleSpec &m, const std::string &what, std::string field = {});

struct SetSpec {
    std::filesystem::path xml_path;
    std::filesystem::path layout;  // <layout> at the root: the set's layout.json (empty: none)
    int layout_line = 0;
    std::vector<ModuleSpec> modules;
    std::vector<ExecutorSpec> executors;  // not including "main"
};

// Limits on what a module.xml may hold.
inline constexpr std::size_t kMaxXmlBytes = 4u << 20;
inline constexpr std::size_t kMaxModules = 1024;
inline constexpr auto kMaxNameLength = static_cast<std::size_t>(protocol::kMaxNameLength);  // protocol/control.json

Result<SetSpec> parseModuleXml(const std::filesystem::path &xml_path);

// Same, from text already in memory; xml_path names the file in messages and anchors relative
// filenames.
Result<SetSpec> parseModuleXmlText(std::string_view text, const std::filesystem::path &xml_path);

}  // namespace irp::config
