// alarming.cpp -- a thread module that raises and clears alarms (docs/alarms.md), for
// test_alarms and test_alarms_irpd.  Properties:
//   declare       "ID SEVERITY TEXT" declared with irp::declareAlarm in initialize() (SEVERITY:
//                 low, medium, high, critical); several separated by ';'
//   ids           the ids its run() keeps level style (irp::alarm(id, condition)) every period
//   toggle_every  the condition changes every N runs (no syscall: the allocation test's case)
//   trigger       else the condition is "this file exists"
//   raise_at_start  an id raised in start() (then left to run())
// The detail of a raise is "run <n>", its value n.
#include <indurop/indurop.h>

#include <unistd.h>

#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

namespace {
std::vector<uint32_t> ids;
uint64_t toggle_every = 0, runs = 0;
uint32_t raise_at_start = 0;
std::string trigger;
char detail[32] = "";

irp::Severity severityNamed(const std::string &s) {
    if (s == "low") return irp::Severity::Low;
    if (s == "high") return irp::Severity::High;
    if (s == "critical") return irp::Severity::Critical;
    return irp::Severity::Medium;
}

bool conditionNow() {
    if (toggle_every) return (runs / toggle_every) % 2 == 1;
    return !trigger.empty() && access(trigger.c_str(), F_OK) == 0;
}
}  // namespace

extern "C" void initialize(irp::Property const &p) {
    std::istringstream list(std::string(p.find("ids").value_or("")));
    for (uint32_t id; list >> id;) ids.push_back(id);
    toggle_every = p.find("toggle_every") ? std::stoull(std::string(*p.find("toggle_every"))) : 0;
    trigger = std::string(p.find("trigger").value_or(""));
    raise_at_start =
        p.find("raise_at_start") ? static_cast<uint32_t>(std::stoul(std::string(*p.find("raise_at_start")))) : 0;
    std::istringstream declarations(std::string(p.find("declare").value_or("")));
    for (std::string one; std::getline(declarations, one, ';');) {
        std::istringstream words(one);
        uint32_t id = 0;
        std::string severity, text;
        if (!(words >> id >> severity)) continue;
        std::getline(words >> std::ws, text);
        irp::declareAlarm(id, severityNamed(severity), text.c_str());
    }
}

void start() {
    runs = 0;
    if (raise_at_start) irp::raiseAlarm(raise_at_start, "raised in start()", -1);
}

void run() {
    ++runs;
    const bool active = conditionNow();
    std::snprintf(detail, sizeof detail, "run %llu", static_cast<unsigned long long>(runs));
    for (uint32_t id : ids) irp::alarm(id, active, detail, static_cast<double>(runs));
}
