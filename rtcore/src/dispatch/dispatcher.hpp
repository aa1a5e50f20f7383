// dispatcher.hpp -- turns a loaded set into running executors: builds each executor's slot table
// from the schedule, starts one RT thread per executor, aligns them on one T0, stops them.  A hot
// reload may add, remove or change executors: their threads are started (parked on an empty table,
// on the running time grid) before the swap and stopped after it (docs/hot-reload.md).  Beside them
// a non-RT stats thread ("irp@stats") folds the figures of the modules' runs from the executors'
// sample rings into the stats block every kFoldIntervalNs (stats/sample_ring.hpp).
#pragma once

#include <indurop/result.hpp>
#include "config/module_xml.hpp"
#include "dispatch/executor.hpp"
#include "schedule/schedule.hpp"
#include "stats/stats_segment.hpp"

#include <atomic>
#include <memory>
#include <string>
#include <functional>
#include <mutex>
#include <optional>
#include <pthread.h>
#include <thread>
#include <vector>

namespace irp::dispatch {

struct DispatcherOptions {
    int rt_priority = 80;  // the main executor; other executors default to one below
    int cpu = -1;          // -1: the last CPU this process may use
    bool realtime = true;  // false: do not even try SCHED_FIFO (development only)
    OverrunPolicy policy = OverrunPolicy::CatchUp;
    int64_t max_catchup_ns = 100'000'000;
    trace::TraceRings *trace = nullptr;  // sampled by the main executor after every slot
    const ForceBoard *forces = nullptr;  // applied by every executor (dispatch/forces.hpp); null: none
};

// A module of the set as the dispatcher runs it, and its stats record.  A thread module has its
// run function (and condition, if sporadic); a process module its control slot; a module with
// neither is not dispatched (non-real processes run beside the dispatcher, supervised).
struct ModuleBinding {
    void (*run)() = nullptr;
    int (*condition)() = nullptr;
    indurop_process_slot *process = nullptr;
    stats::TimingRecord *stats = nullptr;
    // A periodic thread module whose exported functions processes may call: the set's call
    // server (dispatch/function_calls.hpp), which its executor serves right after its run().
    CallServer *calls = nullptr;
    int owner = -1;         // the module's owner id in `calls`
    bool disabled = false;  // taken out of dispatch by request (enable/disable)
    // Thread modules: the module's source in the alarm segment, which its run() and condition()
    // raise alarms on (runtime::setAlarmSource); none: the calls do nothing.
    uint32_t alarm_source = runtime::kNoAlarmSource;
    FaultNote *fault_note = nullptr;  // thread modules: the text of a throw out of run()/condition()
};

// The tables of every executor for one generation of a set, and the tasks they point to.
struct Tables {
    std::vector<std::unique_ptr<Task>> tasks;
    std::vector<Table> executors;   // [0] main, then the set's <executor>s in file order
    std::vector<Task *> by_module;  // per set index: its task, or null (non-real, not dispatched)
    int64_t macro_ns = 0;           // the set's macro period: every executor's grid meets at its multiples
    // Set by the dispatcher that runs them (its constructor, or prepare() before a swap): per
    // table of `executors`, the stats record of its thread and its crash-handler marker (-1: none).
    std::vector<std::size_t> records;
    std::vector<int> markers;
};

// The executor threads a set asks for: "main" (irpd's --rt-priority and --cpu, the CPU resolved to
// the last one irpd may use when not given), then each <executor> in file order (its priority or
// main's minus one, its CPU or main's).  Two generations share a thread for equal name, priority
// and CPU.
std::vector<ExecutorOptions> executorsOf(const config::SetSpec &set, const DispatcherOptions &options);
// CPUs irpd may use and priorities within 1..99; the error names the executor.
Status checkExecutors(const std::vector<ExecutorOptions> &executors);

// Builds the tables of `set`: periodic tasks into each executor's slot table (the schedule's
// order), sporadic ones into its event list (priority order, ties to the earlier in the file).
// bindings[i] belongs to set.modules[i].
std::unique_ptr<Tables> buildTables(const config::SetSpec &set, const schedule::Schedule &schedule,
                                    const std::vector<ModuleBinding> &bindings);

struct ExecutorReport {
    std::string name;
    int cpu = -1;
    int rt_priority = 0;
    bool realtime = false;
    std::string detail;
};

class Dispatcher {
public:
    // One executor per table of `tables` (main, then set.executors), each starting on its table
    // (not owned: keep it alive while it runs).  Records for the executors are taken from
    // `segment` at indices 0..executors-1 (noted in tables.records).
    Dispatcher(const config::SetSpec &set, Tables &tables, stats::StatsSegment &segment, DispatcherOptions options,
               osal::Clock &clock);
    ~Dispatcher();

    // Executors a set needs: "main" plus each <executor> of the set.
    static std::size_t executorCount(const config::SetSpec &set) { return 1 + set.executors.size(); }

    // Checks CPUs and priorities; starts the threads; returns once every thread runs (or failed
    // before its first slot).  duration_ns > 0 stops each executor after exactly that much of the
    // time grid (duration / its basic period slots).
    Status start(int64_t duration_ns);
    void requestStop();
    // Every executor of the running tables ended its loop (a duration given to start()).
    bool finished() const;
    // Waits for every executor thread (call requestStop() first unless a duration was given), then
    // stops the stats thread: the stats block holds every run's figures when it returns.
    void join();
    // Folds every executor's samples into the stats block now (also the stats thread's work).
    void foldStats();
    // How often the stats thread folds: a module's figures reach the stats block this much after
    // its run at the latest (plus the thread's own wake-up latency).
    static constexpr int64_t kFoldIntervalNs = 1'000'000;

    // The running tables' executors, main first: how each thread was set up.
    std::vector<ExecutorReport> reports() const;
    // Every executor thread there is now (main first; during a hot reload also those arriving
    // and leaving), for the overrun watchdog (dispatch/watchdog.hpp); each lives as long as a
    // copy of its pointer.
    std::vector<std::shared_ptr<Executor>> executors() const;
    // Changes whenever executors() would answer another list (cheap: one atomic load).
    uint64_t executorsVersion() const { return executors_version_.load(std::memory_order_acquire); }
    // The oldest force table generation an executor may still read (dispatch/forces.hpp): every
    // executor there is now took a table at least this new at its latest slot.
    uint64_t forcesSeen() const;
    // Set once a fault stopped the set: every executor then runs no module (docs/faults.md).
    std::atomic<bool> &halted() { return halted_; }
    bool isHalted() const { return halted_.load(std::memory_order_relaxed); }
    bool realtime() const;

    // Hot reload (non-RT side, one at a time).  prepare(): the threads `set` needs that do not run
    // yet (a new <executor>, or one whose priority or CPU changed) are started and parked: they
    // run an empty table on the running time grid, so that they take their table at the swap as
    // the running ones do.  Fills next.records and next.markers.  An Error names the executor (a
    // CPU irpd may not use, a priority outside 1..99, or no free stats record in the pool of
    // --module-records, which has the code restart_required).  Nothing changes for the running
    // tables.
    Status prepare(const config::SetSpec &set, Tables &next);
    // The first macro-period boundary of the running tables at or after `t` (they all share the
    // main table's macro period and T0).
    int64_t boundaryAfter(int64_t t) const;
    // Offers every executor its table of `next` (prepared) from the boundary `at` on (see
    // Executor::offer); executors `next` has no table for are offered an empty one.
    void offer(const Tables &next, int64_t at);
    // Each executor's switch (next's order), once all of them switched; then `next` is the
    // running tables.
    std::optional<std::vector<Switch>> switched();
    // Takes back the offers not yet taken; false if some executor already switched (then wait).
    bool withdraw();
    // After a swap: the threads of executors the new tables no longer have are stopped and
    // joined; their records and markers are freed.  Also after a reload that failed after
    // prepare() (then the parked threads go).  Then every run of the old tables is folded, so the
    // records of modules the new set dropped may be freed.
    void retire();

private:
    struct Plan;
    struct StartGate;
    // Starts plan's thread: set up (RT, CPU, stack), wait at `gate`, then loop from its T0.
    Status launch(Plan &plan, const std::shared_ptr<StartGate> &gate, int64_t duration_ns, bool main);
    std::unique_ptr<Plan> makePlan(const ExecutorOptions &options, std::size_t record, const Table *table);
    void release(Plan &plan);  // frees its record and marker (its thread joined)
    static void joinPlan(Plan &plan);

    // plans_: the running tables' executors, in their order.  arriving_: started by prepare(),
    // parked.  next_: per table of the prepared tables, its plan (of plans_ or arriving_).
    // leaving_: after the switch, the executors without a table in the running ones.
    std::vector<std::shared_ptr<Plan>> plans_, arriving_, leaving_;
    std::vector<Plan *> next_;
    mutable std::mutex plans_mutex_;              // the lists above, against executors() and reports()
    std::atomic<uint64_t> executors_version_{0};  // +1 under plans_mutex_ whenever the lists change
    std::vector<bool> marker_used_;
    int64_t epoch_ns_ = 0;  // T0 of the running tables (the first slot, or the last swap)
    int64_t macro_ns_ = 0;  // their macro period
    const Tables *offered_ = nullptr;
    int64_t offered_at_ = 0;
    static constexpr std::size_t kThreadStackBytes = 1u << 20;

    std::atomic<bool> halted_{false};
    std::thread folder_;  // the stats thread
    std::atomic<bool> folder_quit_{false};
    void startFolder();
    stats::StatsSegment &segment_;
    DispatcherOptions options_;
    osal::Clock &clock_;
};

}  // namespace irp::dispatch
