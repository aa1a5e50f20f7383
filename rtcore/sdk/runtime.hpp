// runtime.hpp -- the host side of libindurop: what irpd uses to feed modules their cycle and to
// drain the lines modules wrote with irp::printf.  Not installed for modules.
#pragma once

#include <indurop/alarms.h>
#include <indurop/indurop.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <set>
#include <vector>

namespace irp::runtime {

// Sets what irp::cycle() returns on the calling thread (the dispatcher, before each slot).
void setCycle(const Cycle &cycle) noexcept;

// The "end this run" request behind irp::runAbortRequested(), one per dispatcher thread: `run` is
// the number of the watched run in progress (odd while one runs, even between them: the overrun
// watchdog's run marker, dispatch/watchdog.hpp), `requested` the run the watchdog asked to end.
// A request for a run that already ended never matches a later one.
struct RunAbort {
    std::atomic<uint64_t> run{0};
    std::atomic<uint64_t> requested{UINT64_MAX};
    bool now() const noexcept {
        return requested.load(std::memory_order_relaxed) == run.load(std::memory_order_relaxed);
    }
};
// The request irp::runAbortRequested() reads on the calling thread (a dispatcher's loop sets its
// own before it starts, null after it); null: always false.
void setRunAbort(const RunAbort *abort) noexcept;

// Capacity and line size of the irp::printf ring.
inline constexpr std::size_t kLogLines = 1024;
inline constexpr std::size_t kLogLineBytes = 240;

// Hands every queued line to sink, oldest first; returns how many.  Call from one thread only.
std::size_t drainLog(const std::function<void(std::string_view)> &sink);

// Lines irp::printf dropped because the ring was full, since the process started.
uint64_t droppedLogLines() noexcept;

// Shared functions: the module whose initialize()/start() runs now on this thread (so that its
// exports are recorded as its own), and dropping a module's exports when it is unloaded.  The
// instance tells two loads of a module of the same name apart (a hot reload's old and new one).
void setCurrentModule(const std::string &name, uint64_t instance = 0);
uint64_t currentModuleInstance() noexcept;  // 0: no module's initialize()/start() runs on this thread
void dropFunctionsOf(uint64_t instance);
std::size_t exportedFunctions();

// Every export, sorted by name: what irpd publishes as the function table for process modules.
struct FunctionExport {
    std::string name;
    std::string signature;  // typeid(R(A...)).name()
    std::string owner;      // the module whose initialize()/start() exported it ("" if none)
    detail::AnyFunction fn = nullptr;
    detail::CallShape shape;
};
std::vector<FunctionExport> functionExports();  // the newest export of each name
// The names a module instance exports, and the instances that found one of them (findFunction in
// their initialize() or start(): they may hold its pointer).
std::vector<std::string> exportsOf(uint64_t instance);
std::set<uint64_t> importersOf(uint64_t instance);
// FNV-1a 64 of a typeid name: how a call request names its signature (<indurop/control.h>).
uint64_t signatureHash(const char *signature) noexcept;

// ---- alarms (sdk/alarms.cpp, docs/alarms.md) ------------------------------------------------------
// The alarm segment this process writes to: irpd adopts the one it created (null: none any more);
// a process module maps the one INDUROP_ALARMS names when libindurop loads.
void adoptAlarms(indurop_alarm_header *header) noexcept;
// The source the calling thread's module writes to: the dispatcher sets it before run() and
// condition(), the host before initialize() and start().  kNoAlarmSource: none (the calls do
// nothing, except in a process module, whose every thread has the process's source).
inline constexpr uint32_t kNoAlarmSource = UINT32_MAX;
void setAlarmSource(uint32_t source) noexcept;
// The calling thread's source word itself: a dispatcher's loop takes it once and sets it before
// each module with one store (a call through the PLT and a TLS lookup otherwise, per module).
uint32_t *alarmSourceWord() noexcept;

// An alarm a module declared, in module.xml or by irp::declareAlarm.
struct AlarmDeclaration {
    uint32_t id = 0;
    Severity severity = Severity::Medium;
    std::string text;
    bool from_code = false;  // irp::declareAlarm; else module.xml's <alarm>
};
// Module.xml's declarations of a module instance, given before its initialize(): what
// irp::declareAlarm is checked against.  Replaces what the instance had.
void declareAlarms(uint64_t instance, std::vector<AlarmDeclaration> declarations);
// Every declaration of an instance, by id.
std::vector<AlarmDeclaration> alarmsOf(uint64_t instance);
void dropAlarmsOf(uint64_t instance);

}  // namespace irp::runtime

struct indurop_segment_header;
namespace irp::shared {
// irpd: the segment it created is this process's segment (null: none any more).
void adopt(const indurop_segment_header *header) noexcept;
const indurop_segment_header *segmentHeader() noexcept;
}  // namespace irp::shared
