// executor.hpp -- one dispatcher thread's loop: a slot table walked once per basic period.
//
// The main executor runs the set's slot table (Table 3).  A module may name another executor
// (<executor> in module.xml): that executor is its own SCHED_FIFO thread, at its own priority and
// CPU, with a slot table of its own modules only, on the same time grid (same T0).  A slow module
// there can overrun without delaying the fast ones on the main executor.
#pragma once

#include "config/module_xml.hpp"
#include "dispatch/fault_note.hpp"
#include "dispatch/forces.hpp"
#include "dispatch/watchdog.hpp"
#include "osal/clock.hpp"
#include "sdk/runtime.hpp"
#include "stats/sample_ring.hpp"
#include "stats/stats_block.hpp"

#include <indurop/control.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

namespace irp::trace {
class TraceRings;
}

namespace irp::dispatch {

// What the dispatcher does when it wakes up a whole basic period late (or more), e.g. after the
// previous slot overran or the machine stalled.  Either way the time grid never drifts: slot n is
// always due at T0 + n * basic.
enum class OverrunPolicy {
    // Run the late slots back to back until caught up, so every module gets every run (a
    // trajectory interpolator keeps its time base); beyond max_catchup_ns of backlog, skip.
    CatchUp,
    // Drop the late slots and continue with the slot due now (a PLC task's behaviour).
    Skip,
};

const char *toString(OverrunPolicy policy);

class CallServer;  // dispatch/function_calls.hpp

// How long past the due time a dispatcher that released its slot's process ahead sleeps on the
// process's done word before it looks (docs/process-modules.md): the process normally starts at
// the due time and wakes it when done; this bounds the wait for one that never started (it exited
// meanwhile), after which the slot goes on as for any release.  Half the basic period at most.
inline constexpr int64_t kArmedWaitNs = 50'000;

struct Task;

// A hot swap's one-time work at its boundary (the reloader's converted variables, docs/hot-reload.md):
// every executor offered a table arrives once when it takes it; the last to arrive runs `work` on its
// own thread (it must not allocate, lock or make a system call) and opens the gate.  Until then the
// tasks gated by it skip their runs: they never see what the work has not done yet.
struct SwapGate {
    void (*work)(void *) noexcept = nullptr;
    void *context = nullptr;
    int expected = 0;  // the executors offered a table for the swap (Dispatcher::offer sets it)
    std::atomic<int> arrived{0};
    std::atomic<bool> open{false};

    void arrive() noexcept {
        if (arrived.fetch_add(1, std::memory_order_acq_rel) + 1 != expected) return;
        if (work) work(context);
        open.store(true, std::memory_order_release);
    }
    bool isOpen() const noexcept { return open.load(std::memory_order_acquire); }
};

// What a task is: set when the tables are built (dispatch::buildTables, then the reloader's
// carry-over fields) and never written once the table is offered to an executor.
struct TaskConfig {
    enum class Kind : uint8_t { Thread, Process };
    Kind kind = Kind::Thread;
    bool sporadic = false;                    // run by the event handler, not from the slot table
    void (*run)() = nullptr;                  // thread modules
    int (*condition)() = nullptr;             // sporadic thread modules
    indurop_process_slot *process = nullptr;  // process modules: their control slot
    // A periodic process first in every slot it runs in: released ahead, just before its
    // dispatcher sleeps until the slot (docs/process-modules.md), and told its next due time.
    bool leads = false;
    int64_t deadline_ns = 0;  // sporadic: from condition true / release to completion
    stats::TimingRecord *stats = nullptr;
    int64_t period_ns = 0;
    int64_t period_slots = 1;  // period / the executor's basic period
    int64_t budget_ns = 0;     // 0 = none
    // <on_overrun> / <overrun_limit>: a run longer than the limit is an overrun handled per action
    // (thread modules here; process modules by irpd's main thread, docs/faults.md)
    config::OverrunAction on_overrun = config::OverrunAction::None;
    int64_t overrun_limit_ns = 0;
    // a thread module whose exported functions process modules call: served after its run()
    CallServer *calls = nullptr;
    int module = -1;                                  // its owner id in the call server's table
    bool disabled = false;                            // taken out of dispatch by request: its state starts disabled
    uint32_t alarm_source = runtime::kNoAlarmSource;  // thread modules: set for run() and condition()
    FaultNote *fault_note = nullptr;                  // thread modules: where a throw's text goes (its event)
    // Hot reload: the same module's task in the table this one replaces (kept modules).  At the
    // swap the loop carries its run-time state over (TaskState::carryOver).
    const Task *predecessor = nullptr;
    bool clear_fault = false;        // enabled again: a fault's disable is not carried over
    const SwapGate *gate = nullptr;  // its runs are skipped until this gate opens (null: none)
};

// What the executor thread learns while it runs a task; written by that thread only (and copied
// from the predecessor's at a swap, on the same thread).  Plain data: a carry-over is a few stores.
struct TaskState {
    int64_t t0 = 0;         // first start (T0 of Eq. (1))
    int64_t first_due = 0;  // the due time of the slot of its first start: run n is due first_due + n * period
    int64_t run_due = 0;    // the due time of its current run on its own grid: first_due + n * period
    bool started = false;
    bool disabled = false;           // by request (TaskConfig::disabled), a throw or <on_overrun>disable
    int64_t skip_until = INT64_MIN;  // on_overrun=skip: runs due before this are dropped
    // a sporadic process's release in flight
    bool in_flight = false;
    bool deadline_missed = false;
    uint32_t released_seq = 0;
    int64_t released_at = 0;

    // The hot-reload carry-over from the predecessor's state `before`: Eq. (1)'s T0 when the
    // period did not change, a fault's disable unless it was cleared, the skip window and a
    // sporadic process's release in flight.
    void carryOver(const TaskState &before, bool same_period, bool clear_fault) noexcept {
        if (same_period) {
            started = before.started;
            t0 = before.t0;
            first_due = before.first_due;
            run_due = before.run_due;
        }
        disabled = disabled || (before.disabled && !clear_fault);
        skip_until = before.skip_until;
        in_flight = before.in_flight;
        deadline_missed = before.deadline_missed;
        released_seq = before.released_seq;
        released_at = before.released_at;
    }
};
static_assert(std::is_trivially_copyable_v<TaskState>, "carried over at a swap on the RT thread: plain stores only");

// One module's place in an executor: its configuration and its run-time state.
struct Task {
    using Kind = TaskConfig::Kind;
    TaskConfig config;
    TaskState state;

    Task() = default;
    explicit Task(const TaskConfig &c) : config(c) { state.disabled = c.disabled; }
};

// One executor's work for one generation of the set: its basic period, the slot table (tasks in
// run order per slot), the periodic tasks, and the sporadic ones in priority order.  Immutable
// once handed to an executor, except for the tasks' state, which only that executor's thread
// writes.
struct Table {
    int64_t basic_ns = 0;
    std::vector<std::vector<Task *>> slots;
    std::vector<Task *> tasks;
    std::vector<Task *> events;
    SwapGate *gate = nullptr;  // arrived at when an executor takes this table (null: none)
    int64_t macroNs() const { return basic_ns * static_cast<int64_t>(slots.size()); }
};

// Where and when an executor took over an offered table.
struct Switch {
    uint64_t cycle = 0;  // its slot count at the switch: the first slot run from the new table
    int64_t due_ns = 0;  // that slot's due time
};

struct ExecutorOptions {
    std::string name = "main";
    int rt_priority = 80;
    int cpu = -1;  // -1: do not pin
    OverrunPolicy policy = OverrunPolicy::CatchUp;
    int64_t max_catchup_ns = 100'000'000;
    trace::TraceRings *trace = nullptr;  // sampled after every slot's work (the main executor's)
    // Set (by a watchdog or an executor) when a fault stopped the set: from then on no executor
    // runs any module.  Shared by all executors of a dispatcher; null = never halted.
    std::atomic<bool> *halted = nullptr;
    int marker = -1;  // its running marker for the crash handler (running_marker.hpp); -1: none
    // The forces applied before and after each module (dispatch/forces.hpp); null: none.
    const ForceBoard *forces = nullptr;
    // Module runs whose figures its sample ring holds until they are folded into the stats block
    // (stats/sample_ring.hpp): a fold every millisecond leaves room for several milliseconds of
    // 100 modules at a 100 us basic period.
    std::size_t sample_capacity = 4096;
};

class Executor {
public:
    // Runs `table` (not owned: it must outlive the loop or its replacement).  self: this
    // dispatcher's own record.
    Executor(osal::Clock &clock, const Table *table, stats::TimingRecord *self, ExecutorOptions options);
    // The same with a table of its own: slots[i] the tasks of slot i in run order; tasks every
    // periodic task; events the sporadic tasks in priority order (the event handler's list).
    Executor(osal::Clock &clock, int64_t basic_ns, std::vector<std::vector<Task *>> slots, std::vector<Task *> tasks,
             stats::TimingRecord *self, ExecutorOptions options, std::vector<Task *> events = {});
    Executor(const Executor &) = delete;
    Executor &operator=(const Executor &) = delete;

    // The RT loop.  Slot n is due at t0 + n * basic.  Returns when `stop` is set (checked every
    // slot) or after cycle_limit slots (0 = no limit).  `cycles`, if given, counts slots done;
    // `finished_ns`, if given, receives the time the last slot's work ended.
    void loop(int64_t t0, uint64_t cycle_limit, const std::atomic<bool> &stop, stats::Counter *cycles,
              std::atomic<int64_t> *finished_ns = nullptr);

    const ExecutorOptions &options() const { return options_; }
    // Folds the module figures the loop left in its sample ring into their records (runs and the
    // jitter, latency and execution-time histograms): any non-RT thread (Dispatcher's stats thread,
    // the reloader before it frees records); loop() folds the rest itself when it ends.  Returns
    // how many runs it folded.
    std::size_t foldStats();
    int64_t basicNs() const { return basic_ns_.load(std::memory_order_relaxed); }
    // The watchdog's view (dispatch/watchdog.hpp): the watched run in progress and the outcomes;
    // watching(): the running table has a module with <on_overrun>.
    RunMarker &marker() { return marker_; }
    bool watching() const { return watching_.load(std::memory_order_relaxed); }
    // Takes back a release made ahead that its process has not started yet (any thread: the
    // watchdog, when a fault stops the set): the process reports it done without running it.
    void cancelArmed() noexcept;
    // The generation of the force table the loop took at its latest slot (0: no slot yet;
    // UINT64_MAX: the loop ended): tables older than it are no longer read (dispatch/forces.hpp).
    uint64_t forceSeen() const noexcept { return force_seen_.load(std::memory_order_acquire); }

    // Hot reload, from a non-RT thread.  offer(): the loop switches to `next` at the first slot due
    // at or after `at` (a macro-period boundary of the running table, on the common time grid),
    // before running anything of that slot; the grid is re-anchored there (the new basic period
    // may differ).  One offer at a time.  switched(): the switch once it happened, after which
    // the old table is no longer touched by the loop.  withdraw(): takes an offer back that was
    // not taken yet (false: too late, it was taken).
    void offer(const Table *next, int64_t at);
    std::optional<Switch> switched() const;
    bool withdraw();

private:
    void skip(uint64_t from_cycle, uint64_t count);
    void runThread(Task &task, stats::TimingRecord &r);
    // Serves the calls from process modules waiting for task's functions (none without a call server).
    void serveCalls(Task &task, uint64_t cycle);
    // Releases a periodic process and waits (futex) until it reports the period done, at most
    // until `wait_until`.  False if it was not ready to be released.
    bool runProcess(Task &task, uint64_t cycle, int64_t due, int64_t start, int64_t wait_until);
    // Writes what the process reads of its release at `cycle`, due at `due` (irp::cycle(), its
    // next due time), made at `start`, to run from `at` (0: at once), and makes the release.
    void release(Task &task, uint64_t cycle, int64_t due, int64_t start, int64_t at);
    // Instead of sleeping until `due`: releases the slot's leading process ahead (control.h), when
    // it runs in that slot and is ready, and sleeps on its done word (the process, woken by its own
    // timer at `due`, wakes this thread when it is done) for at most kArmedWaitNs past `due`.  The
    // release is armed_ until resolveArmed().  False when nothing was released ahead (then sleep).
    bool armAhead(const std::vector<Task *> &order, uint64_t cycle, int64_t due);
    // After the wake-up for the armed slot: whether its process claimed the release, else it is
    // made a release now (woken as any) or, when the slot must not run it, taken back.  `start`
    // becomes when the process started.
    enum class Armed : uint8_t { Claimed, Released, TakenBack };
    Armed resolveArmed(Task &task, int64_t now, int64_t &start);
    // Waits until done_seq moves past `served`, at most until `until` (`now`: a clock read taken
    // before the release); false at the bound.
    bool awaitDone(indurop_process_slot &slot, uint32_t served, int64_t now, int64_t until);
    // The event handler (Figure 6): conditions of sporadic threads, then releases of sporadic processes.
    int64_t handleEvents(uint64_t cycle, int64_t due, int64_t t);
    void disable(Task &task, stats::TimingRecord &r, const char *what, const char *detail);
    // A run's figures into the sample ring (`what`: stats::RunSample's bits); a full ring counts
    // the loss in stats_dropped (the module's and this dispatcher's) and never waits.
    void post(stats::TimingRecord &r, uintptr_t what, int64_t jitter, uint64_t latency, uint64_t exec) noexcept {
        if (!samples_.push({reinterpret_cast<uintptr_t>(&r) | what, jitter, latency, exec})) {
            stats::bump(r.stats_dropped);
            stats::bump(self_->stats_dropped);
        }
    }
    // A watched thread module's run ended past its overrun limit: count it, apply its action.
    void overran(Task &task, stats::TimingRecord &r, uint64_t run, int64_t start, int64_t end);
    bool halted() const { return options_.halted && options_.halted->load(std::memory_order_relaxed); }
    // Whether `task` runs in the slot due at `due`: not halted, not disabled, not skipping its runs.
    bool runsNow(const Task &task, int64_t due) const {
        return !halted() && !task.state.disabled && task.state.skip_until <= due;
    }
    // The forces of the slot's table into the variables (no-op without forces).
    void force() const noexcept { applyForces(forces_); }
    // The switch to an offered table, on the RT thread (no allocation: carries the kept tasks' state).
    void takeOver(const Table *next);

    osal::Clock &clock_;
    std::size_t crash_marker_ = SIZE_MAX;  // options_.marker while the loop runs (markRunning ignores SIZE_MAX)
    std::unique_ptr<Table> own_;           // the table of the second constructor
    const Table *table_;
    stats::TimingRecord *self_;
    ExecutorOptions options_;
    // the offer: at_ is written before next_ (release); the loop reads next_ (acquire) then at_
    std::atomic<const Table *> next_{nullptr};
    std::atomic<int64_t> next_at_{0};
    std::atomic<uint64_t> switched_cycle_{0};
    std::atomic<int64_t> switched_due_{0};
    std::atomic<bool> switched_{false};
    RunMarker marker_;
    std::atomic<bool> watching_{false};
    // The release made ahead and not resolved yet (cancelArmed() may take it back from another
    // thread): its slot and its release_at_ns.
    std::atomic<indurop_process_slot *> armed_{nullptr};
    std::atomic<int64_t> armed_at_{0};
    uint32_t *alarm_source_ = nullptr;    // this thread's alarm source word, while loop() runs
    const ForceTable *forces_ = nullptr;  // the force table taken at the slot's start
    std::atomic<uint64_t> force_seen_{0};
    std::atomic<int64_t> basic_ns_{0};
    stats::SampleRing samples_;
    std::mutex fold_mutex_;  // one consumer of samples_ at a time
    void noteTable(const Table &table);
};

}  // namespace irp::dispatch
