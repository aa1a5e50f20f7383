// reloader.hpp -- hot reload: a new set (or the running one with a period, priority or enable
// changed) is prepared off the RT threads and swapped in at a macro-period boundary.
//
//   plan      parse, schedule, check (layout, executors, shared functions); hash every module
//             file; keep the modules whose file content, type, operation and properties are
//             unchanged (same instance, same state, same stats record, same process); estimate
//             the utilization (over 100 %: refused).  No side effect: a dry run stops here.
//   realize   give every module its alarm source (reload/alarm_sources.hpp); load the other
//             modules from content-addressed copies (hosts/module_cache.hpp), initialize and
//             start them, start the new processes and wait until they are ready; build the
//             executors' tables.  Any failure undoes what it did: the running set is
//             untouched and the Error says why.  (prepare = plan + realize.)
//   swap      each executor takes its new table at the first slot due at or after the boundary
//             (a pointer exchange on its own thread, Executor::offer), carrying the kept tasks'
//             state over; the last one converts the retyped variables whose values are kept
//             (dispatch::SwapGate, variables/conversion.hpp); the reloader waits until all did.
//   retire    stops the modules the new set no longer runs (the RT threads let go of them at
//             the swap), unloads them, stops their processes, frees their records and alarm
//             sources.
//
// Every swap returns a report (docs/hot-reload.md) and adds a "swap" event.  One reload at a time,
// from irpd's main thread (the process supervisor's thread); the control thread reads
// current() at any time.
#pragma once

#include "alarms/alarm_segment.hpp"
#include <indurop/result.hpp>
#include "dispatch/dispatcher.hpp"
#include "dispatch/function_calls.hpp"
#include "events/event_log.hpp"
#include "hosts/control_segment.hpp"
#include "hosts/module_cache.hpp"
#include "hosts/process_supervisor.hpp"
#include "protocol/limits.hpp"
#include "reload/generation.hpp"
#include "stats/stats_segment.hpp"
#include "trace/trace_rings.hpp"
#include "variables/variable_segment.hpp"

#include <nlohmann/json.hpp>

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace irp::reload {

// What the reloader works with; all owned by the daemon and alive longer than the reloader.
struct Services {
    stats::StatsSegment *stats = nullptr;
    std::size_t executors = 1;                   // dispatcher records before the modules'
    variables::VariableSegment *vars = nullptr;  // null: irpd runs without shared variables
    hosts::ControlSegment *control = nullptr;    // the process modules' slots
    hosts::ProcessSupervisor *supervisor = nullptr;
    hosts::ModuleCache *cache = nullptr;
    events::EventLog *events = nullptr;
    dispatch::CallServer *calls = nullptr;   // the shared-function table for processes, if any
    trace::TraceRings *trace = nullptr;      // told the basic period after a swap that changes it
    alarms::AlarmSegment *alarms = nullptr;  // the modules' alarm sources (reload/alarm_sources.hpp); null: none
    schedule::Limits limits;
    dispatch::DispatcherOptions dispatcher;  // the RT priority and CPU processes inherit
    std::set<int> kept_off;                  // CPUs irpd's non-RT threads were kept off at start (empty: none)
    // Modules left out of a set after they crashed irpd (supervise/crash_record.hpp): a `load`
    // of that set starts them disabled; an `enable` of one calls forgive.  Empty: none.
    std::function<std::set<std::string>(const config::SetSpec &)> left_out;
    std::function<void(const std::string &module)> forgive;
    // After every swap, with the generation that took over (the forces resolved in its layout).
    std::function<void(const Generation &)> swapped;
    int64_t ready_timeout_ns = 5'000'000'000;  // new processes: until irp::initPeriodExe()
    int64_t swap_timeout_ns = 10'000'000'000;  // offer -> every executor switched
};

// Values of one module of the running set changed (a hot reload of the same set).
struct Change {
    std::string module;
    std::optional<int64_t> period_ns;
    std::optional<int> priority;
    std::optional<bool> enabled;
};

// Estimated busy fraction per executor ("main" and every <executor>): execution time p99 measured
// for the modules kept, <budget> for new ones, over their periods.  Above 1 a reload is refused.
struct Estimate {
    std::map<std::string, double> busy;
};

class Reloader {
public:
    explicit Reloader(Services services) : s_(services) {}

    // Prepares a generation of `set` after `running` (null: the first one).  before_processes
    // runs after the thread modules started and before any new process starts (the first
    // generation publishes the shared-function table there).
    Result<std::unique_ptr<Generation>> prepare(config::SetSpec set, const Generation *running,
                                                std::set<std::string> disabled, std::string set_id,
                                                const std::function<Status(Generation &)> &before_processes = {});

    // The first generation runs on `dispatcher` from now on.
    void adopt(std::unique_ptr<Generation> first, dispatch::Dispatcher &dispatcher);
    void setCallServer(dispatch::CallServer *calls) { s_.calls = calls; }
    void setControl(hosts::ControlSegment *control) { s_.control = control; }

    // Hot reloads (main thread).  The result is the swap report.
    Result<nlohmann::ordered_json> load(const std::filesystem::path &xml, const std::string &set_id);
    Result<nlohmann::ordered_json> change(const Change &change);
    // Several modules changed as one reload: {"dry_run", "before", "schedule", "utilization",
    // "warnings", "report"} (docs/control-protocol.md, `change`).  dry_run: planned and checked as
    // a real change is, answered, and dropped; nothing is loaded, swapped or logged.  An unknown
    // module is an Error with code "not_found".
    Result<nlohmann::ordered_json> change(const std::vector<Change> &changes, bool dry_run);
    // Everything prepare checks before loading anything: {"valid", "errors", "warnings", "schedule"}.
    nlohmann::ordered_json check(const std::filesystem::path &xml) const;

    // What a set's schedule must satisfy (the minimum basic period, the slot count).
    const schedule::Limits &limits() const { return s_.limits; }

    // The running generation (any thread).
    std::shared_ptr<const Generation> current() const;

    // At the end, after the dispatcher stopped: stop() of every started thread module, in file
    // order; the messages of those that threw.
    std::vector<std::string> stopAll();

private:
    // prepare = plan (decide and check, no side effect) + realize (load, start, build the tables).
    Result<std::unique_ptr<Generation>> plan(config::SetSpec set, const Generation *running,
                                             std::set<std::string> disabled, std::string set_id,
                                             Estimate *estimate = nullptr) const;
    Status realize(Generation &next, const Generation *running,
                   const std::function<Status(Generation &)> &before_processes = {});
    Result<nlohmann::ordered_json> swap(std::unique_ptr<Generation> next, int64_t requested_ns);
    // out (optional) gets the set's layout and its diff against the segment's.
    Status checkAgainst(const config::SetSpec &set, const Generation *running, Generation *out = nullptr) const;
    // Free stats records for next's new modules and new executor threads (`threads` against
    // `running_threads`); restart_required naming them and --module-records when short.
    Status checkRecordRoom(const Generation &next, const std::vector<dispatch::ExecutorOptions> &threads,
                           const std::vector<dispatch::ExecutorOptions> &running_threads) const;
    void retire(const Generation &old, const Generation &next);
    void undo(Generation &partial);

    Services s_;
    dispatch::Dispatcher *dispatcher_ = nullptr;
    mutable std::mutex mutex_;  // guards current_ (the pointer, not the generation)
    std::shared_ptr<Generation> current_;
};

// The slot table of a generation (schedule::toJson), each module with its `enabled` flag.
nlohmann::ordered_json scheduleJson(const Generation &g);

// Resolves the set's layout: `override` (--layout), else its <layout>, else layout.json beside
// module.xml when there is one.
void resolveLayout(config::SetSpec &set, const std::filesystem::path &override_path = {});

}  // namespace irp::reload
