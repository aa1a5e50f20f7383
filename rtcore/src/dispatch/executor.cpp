// executor.cpp -- the RT loop.  Everything below loop()'s first line runs on a SCHED_FIFO thread:
// no allocation, no locks, no syscalls but clock_gettime (vDSO), clock_nanosleep and process releases'
// futexes (the fold of the last samples after the loop takes a lock: the loop is over then).
#include "dispatch/executor.hpp"

#include "dispatch/function_calls.hpp"
#include "dispatch/running_marker.hpp"
#include "hosts/control_segment.hpp"
#include "sdk/runtime.hpp"
#include "trace/trace_rings.hpp"

#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <exception>

namespace irp::dispatch {

void claimRunningMarker(std::size_t index, const char *executor) {
    if (index >= kMaxMarkedExecutors) return;
    RunningMarker &m = g_running_markers[index];
    std::snprintf(m.executor, sizeof m.executor, "%s", executor);
    m.module.store(nullptr, std::memory_order_relaxed);
    m.tid.store(static_cast<int>(syscall(SYS_gettid)), std::memory_order_relaxed);
}

const char *toString(OverrunPolicy policy) { return policy == OverrunPolicy::CatchUp ? "catch-up" : "skip"; }

Executor::Executor(osal::Clock &clock, const Table *table, stats::TimingRecord *self, ExecutorOptions options)
    : clock_(clock), table_(table), self_(self), options_(std::move(options)), samples_(options_.sample_capacity) {
    noteTable(*table_);
}

Executor::Executor(osal::Clock &clock, int64_t basic_ns, std::vector<std::vector<Task *>> slots,
                   std::vector<Task *> tasks, stats::TimingRecord *self, ExecutorOptions options,
                   std::vector<Task *> events)
    : clock_(clock),
      own_(new Table{basic_ns, std::move(slots), std::move(tasks), std::move(events)}),
      table_(own_.get()),
      self_(self),
      options_(std::move(options)),
      samples_(options_.sample_capacity) {
    noteTable(*table_);
}

std::size_t Executor::foldStats() {
    std::lock_guard lock(fold_mutex_);
    return samples_.fold();
}

void Executor::noteTable(const Table &table) {
    bool watched = false;
    for (const Task *t : table.tasks) {
        watched =
            watched || (t->config.kind == Task::Kind::Thread && t->config.on_overrun != config::OverrunAction::None);
    }
    watching_.store(watched, std::memory_order_relaxed);
    basic_ns_.store(table.basic_ns, std::memory_order_relaxed);
}

void Executor::offer(const Table *next, int64_t at) {
    switched_.store(false, std::memory_order_relaxed);
    next_at_.store(at, std::memory_order_relaxed);
    next_.store(next, std::memory_order_release);
}

std::optional<Switch> Executor::switched() const {
    if (!switched_.load(std::memory_order_acquire)) return std::nullopt;
    return Switch{switched_cycle_.load(std::memory_order_relaxed), switched_due_.load(std::memory_order_relaxed)};
}

bool Executor::withdraw() {
    const Table *offered = next_.load(std::memory_order_relaxed);
    return offered && next_.compare_exchange_strong(offered, nullptr, std::memory_order_acq_rel);
}

void Executor::takeOver(const Table *next) {
    for (const auto *list : {&next->tasks, &next->events})
        for (Task *task : *list)
            if (const Task *before = task->config.predecessor)
                task->state.carryOver(before->state, before->config.period_ns == task->config.period_ns,
                                      task->config.clear_fault);
    if (next->gate) next->gate->arrive();
    table_ = next;
    noteTable(*next);
}

void Executor::disable(Task &task, stats::TimingRecord &r, const char *what, const char *detail) {
    task.state.disabled = true;
    // Its state and the text first: the `errors` count is what announces the fault (its event).
    r.state.store(static_cast<uint32_t>(stats::ModuleState::Disabled), std::memory_order_relaxed);
    if (task.config.fault_note) task.config.fault_note->note(what, detail);
    stats::bump(r.errors);
    irp::printf("irpd: module '%s' threw %s from %s; disabled\n", r.name, detail, what);
}

void Executor::overran(Task &task, stats::TimingRecord &r, uint64_t run, int64_t start, int64_t end) {
    Fault f;
    f.kind = Fault::Kind::Returned;
    f.action = task.config.on_overrun;
    f.record = &r;
    f.executor = options_.name.c_str();
    f.started_ns = start;
    f.limit_ns = task.config.overrun_limit_ns;
    f.elapsed_ns = end - start;
    f.seen_ns = end;
    f.seen_running = marker_.seen(run);
    switch (task.config.on_overrun) {
    case config::OverrunAction::Skip: task.state.skip_until = end; break;  // its runs due while it ran are dropped
    case config::OverrunAction::Disable:
        task.state.disabled = true;
        r.state.store(static_cast<uint32_t>(stats::ModuleState::Disabled), std::memory_order_relaxed);
        break;
    case config::OverrunAction::Stop:
        if (options_.halted) options_.halted->store(true, std::memory_order_relaxed);
        break;
    default: break;
    }
    marker_.post(f);  // the watchdog turns it into an event (and runs the stop action if not done yet)
}

void Executor::runThread(Task &task, stats::TimingRecord &r) {
    *alarm_source_ = task.config.alarm_source;  // its irp::raiseAlarm calls are its own
    try {
        task.config.run();
    } catch (const std::exception &e) {
        disable(task, r, "run()", e.what());
    } catch (...) {
        disable(task, r, "run()", "a non-standard exception");
    }
    force();  // what it wrote to a forced variable is seen by nobody
}

void Executor::serveCalls(Task &task, uint64_t cycle) {
    if (task.config.calls) task.config.calls->serve(task.config.module, cycle, task.state.disabled);
}

namespace {

// Run n of a task is due first_due + n * period, n = (due - first_due) / period: from its last
// run's, one period on, without a division (a 64-bit idiv per module otherwise).
int64_t runDue(TaskState &s, int64_t due, int64_t period) noexcept {
    const int64_t since = due - s.run_due;
    if (since >= period && since < 2 * period)
        s.run_due += period;
    else if (since < 0 || since >= period)
        s.run_due = s.first_due + (due - s.first_due) / period * period;
    return s.run_due;
}

// The bound of a periodic process's release made at `start`: its budget, else the period's end.
int64_t waitBound(const TaskConfig &c, int64_t start, int64_t period_end) noexcept {
    return c.budget_ns ? start + c.budget_ns : period_end;
}

}  // namespace

void Executor::release(Task &task, uint64_t cycle, int64_t due, int64_t start, int64_t at) {
    indurop_process_slot &slot = *task.config.process;
    std::atomic_ref<uint32_t> release(slot.release_seq);
    slot.cycle = cycle;
    slot.planned_ns = due;
    slot.basic_ns = table_->basic_ns;
    slot.release_ns = at ? at : start;
    // A periodic process sleeps until its next release's due time by itself (irp::waitPeriod).
    slot.next_due_ns = task.config.sporadic ? 0 : due + task.config.period_ns;
    std::atomic_ref<int64_t>(slot.release_at_ns).store(at, std::memory_order_relaxed);
    release.store(release.load(std::memory_order_relaxed) + 1, std::memory_order_seq_cst);
    // Its wait ends by itself by then (its timer has expired, or expires at `at`), or it needs the
    // wake: control.h, the store above and this load against its own.
    const int64_t wakes_at = std::atomic_ref<int64_t>(slot.wake_ns).load(std::memory_order_seq_cst);
    if (wakes_at == 0 || wakes_at > (at ? at : start)) futex::wakeAll(&slot.release_seq);
}

bool Executor::runProcess(Task &task, uint64_t cycle, int64_t due, int64_t start, int64_t wait_until) {
    indurop_process_slot &slot = *task.config.process;
    std::atomic_ref<uint32_t> state(slot.state), release_seq(slot.release_seq), done(slot.done_seq);
    const uint32_t served = release_seq.load(std::memory_order_relaxed);
    // Ready means waiting in irp::waitPeriod() with the last release finished.
    if (state.load(std::memory_order_acquire) != INDUROP_PROCESS_READY ||
        done.load(std::memory_order_acquire) != served)
        return false;
    if (task.config.sporadic) {  // the event handler checks completion later
        release(task, cycle, due, start, 0);
        return true;
    }
    release(task, cycle, due, start, 0);
    if (!awaitDone(slot, served, start, wait_until)) stats::bump(task.config.stats->overruns);
    force();  // what it wrote to a forced variable is seen by nobody
    return true;
}

bool Executor::armAhead(const std::vector<Task *> &order, uint64_t cycle, int64_t due) {
    if (order.empty()) return false;
    Task &task = *order.front();
    const TaskConfig &c = task.config;
    if (!c.leads || c.sporadic || !runsNow(task, due) || (c.gate && !c.gate->isOpen())) return false;
    indurop_process_slot &slot = *c.process;
    std::atomic_ref<uint32_t> done(slot.done_seq);
    const uint32_t served = std::atomic_ref<uint32_t>(slot.release_seq).load(std::memory_order_relaxed);
    if (std::atomic_ref<uint32_t>(slot.state).load(std::memory_order_acquire) != INDUROP_PROCESS_READY ||
        done.load(std::memory_order_acquire) != served)
        return false;  // not ready: the slot finds it so and counts the miss
    armed_at_.store(due, std::memory_order_relaxed);
    armed_.store(&slot, std::memory_order_release);
    release(task, cycle, due, clock_.now(), due);
    // Asleep on its done word, not on a timer of its own at `due`: at that time only the process's
    // timer fires, and it runs at once; its report wakes this thread.
    const int64_t until = due + std::min(kArmedWaitNs, table_->basic_ns / 2);
    while (done.load(std::memory_order_acquire) == served)
        if (!clock_.waitUntil(&slot.done_seq, served, until)) break;
    return true;
}

Executor::Armed Executor::resolveArmed(Task &task, int64_t now, int64_t &start) {
    indurop_process_slot &slot = *task.config.process;
    std::atomic_ref<int64_t> at(slot.release_at_ns);
    int64_t expected = armed_at_.load(std::memory_order_relaxed);
    // Not ready any more (exited or restarting meanwhile: the slot finds it so), or the slot must
    // not run it: taken back (a process that is there reports it done without running it).
    const bool run = runsNow(task, expected) &&
                     std::atomic_ref<uint32_t>(slot.state).load(std::memory_order_acquire) == INDUROP_PROCESS_READY;
    armed_.store(nullptr, std::memory_order_relaxed);
    if (at.compare_exchange_strong(expected, run ? 0 : INDUROP_RELEASE_CANCELLED, std::memory_order_acq_rel)) {
        if (!run) return Armed::TakenBack;
        // Not started within kArmedWaitNs of its due time (the machine held it off): a release now.
        slot.release_ns = now;
        const int64_t wakes_at = std::atomic_ref<int64_t>(slot.wake_ns).load(std::memory_order_seq_cst);
        if (wakes_at == 0 || wakes_at > now) futex::wakeAll(futex::lowWord(&slot.release_at_ns));
        start = now;
        return Armed::Released;
    }
    if (expected == INDUROP_RELEASE_CANCELLED) return Armed::TakenBack;                 // by cancelArmed()
    start = std::atomic_ref<int64_t>(slot.started_ns).load(std::memory_order_relaxed);  // claimed: 0 now
    return Armed::Claimed;
}

void Executor::cancelArmed() noexcept {
    indurop_process_slot *slot = armed_.load(std::memory_order_acquire);
    if (!slot) return;
    int64_t expected = armed_at_.load(std::memory_order_relaxed);
    std::atomic_ref<int64_t>(slot->release_at_ns)
        .compare_exchange_strong(expected, INDUROP_RELEASE_CANCELLED, std::memory_order_acq_rel);
}

bool Executor::awaitDone(indurop_process_slot &slot, uint32_t served, int64_t now, int64_t until) {
    std::atomic_ref<uint32_t> done(slot.done_seq);
    while (done.load(std::memory_order_acquire) == served) {
        if (until <= now) return false;
        // Its own timer, at the absolute bound: not a watchdog that looks every basic period
        // (docs/benchmark.md: such looks on the other CPU made this CPU's timers fire late).
        clock_.waitUntil(&slot.done_seq, served, until);
        now = clock_.now();
    }
    return true;
}

int64_t Executor::handleEvents(uint64_t cycle, int64_t due, int64_t t) {
    for (Task *task : table_->events) {
        const TaskConfig &c = task->config;
        TaskState &s = task->state;
        if (s.disabled || (c.gate && !c.gate->isOpen())) continue;
        stats::TimingRecord &r = *c.stats;
        if (c.kind == Task::Kind::Thread) {
            int fired = 0;
            markRunning(crash_marker_, r.name);
            *alarm_source_ = c.alarm_source;
            try {
                fired = c.condition();
            } catch (...) {
                disable(*task, r, "condition()", "an exception");
                continue;
            }
            const int64_t checked = t;
            t = clock_.now();
            if (!fired) continue;
            const int64_t start = t;
            runThread(*task, r);
            t = clock_.now();
            using S = stats::RunSample;
            post(r, S::kLatency | S::kExec | S::kRun, 0, static_cast<uint64_t>(start - checked),
                 static_cast<uint64_t>(t - start));
            if (t - checked > c.deadline_ns) stats::bump(r.missed);  // condition true -> done
            continue;
        }
        // A sporadic process: released every basic period to check its own condition (Figure 8);
        // the dispatcher does not wait, it checks completion against the deadline afterwards.
        indurop_process_slot &slot = *c.process;
        if (s.in_flight) {
            std::atomic_ref<uint32_t> done(slot.done_seq);
            if (done.load(std::memory_order_acquire) == s.released_seq) {
                s.in_flight = false;
                force();
                const int64_t took = slot.done_ns - s.released_at;
                post(r, stats::RunSample::kExec | stats::RunSample::kRun, 0, 0,
                     static_cast<uint64_t>(took > 0 ? took : 0));
                if (took > c.deadline_ns && !s.deadline_missed) stats::bump(r.missed);
            } else {
                if (!s.deadline_missed && t - s.released_at > c.deadline_ns) {
                    s.deadline_missed = true;
                    stats::bump(r.missed);
                }
                continue;  // still working on the last release
            }
        }
        if (runProcess(*task, cycle, due, t, 0)) {
            s.in_flight = true;
            s.deadline_missed = false;
            s.released_seq = std::atomic_ref<uint32_t>(slot.release_seq).load(std::memory_order_relaxed);
            s.released_at = t;
            post(r, stats::RunSample::kLatency, 0, static_cast<uint64_t>(t - due > 0 ? t - due : 0), 0);
        }
    }
    return t;
}

// Counts the runs that skipping slots [from, from + count) takes from each task.
void Executor::skip(uint64_t from, uint64_t count) {
    stats::bump(self_->skipped, count);
    for (Task *t : table_->tasks) {
        auto ps = static_cast<uint64_t>(t->config.period_slots);
        uint64_t due = (from + count + ps - 1) / ps - (from + ps - 1) / ps;  // multiples of ps in the range
        if (due) stats::bump(t->config.stats->skipped, due);
    }
}

/*
 * One iteration = one basic period:
 *   1. sleep until the slot's absolute due time T0 + n * basic (clock_nanosleep TIMER_ABSTIME),
 *      unless the previous slot ended past it (then start at once: a caught-up slot); a periodic
 *      process that leads the slot is released ahead instead, to start at the due time on its own
 *      timer (control.h), and the dispatcher sleeps on its done word (at most kArmedWaitNs past the
 *      due time); the release is resolved right after: claimed by the process (awaited), made a
 *      release now, or taken back (docs/process-modules.md);
 *   2. if the backlog passed what the overrun policy allows, skip slots to the current one; if the
 *      slot's first module is a process, release and await it now (step 3), so that nothing of
 *      this thread's own comes between its wake-up and the process's; then account the wake-up:
 *      latency (woke - due), a miss if a whole period late; Eq. (1) jitter;
 *   3. run the slot's modules in priority order; for each: Eq. (1) jitter against its own T0 and
 *      period, start latency, execution time, budget overrun; a throw disables the module.  The
 *      run's jitter, latency and execution time go as one sample into the executor's sample ring
 *      (stats/sample_ring.hpp), which irpd's stats thread folds into the module's histograms and
 *      run count; misses, overruns, skips and errors are counted here at once.  A
 *      module with <on_overrun> has its run() marked for the watchdog (dispatch/watchdog.hpp),
 *      and a run past its <overrun_limit> gets its action: warn, skip (its runs due meanwhile are
 *      dropped), disable, or stop (no module of any executor runs any more).  A
 *      process module is released (futex; the FUTEX_WAKE left out when the process's own timer
 *      has already ended its wait, control.h) and awaited in its place, bounded by its budget or by
 *      the end of the basic period (an overrun if it does not finish by then).  Right after a
 *      thread module's run(), the calls that process modules made to its exported functions are
 *      served (at most irp::kCallsServedPerPeriod, included in its exec time; a disabled module
 *      answers them with an error).  Before a thread module's run() the running marker names it
 *      (one relaxed store, dispatch/running_marker.hpp: the crash handler reads it);
 *   4. the event handler (Figure 6): condition() of each sporadic thread module in priority
 *      order, run() where it returned true; then each sporadic process that finished its last
 *      release is released to check its own condition (not awaited; its completion is checked
 *      against its deadline in the following basic periods);
 *   5. sample the traced variables into the trace rings (main executor only, trace/);
 *      the forces (dispatch/forces.hpp) are applied at the slot's start (the table taken then, its
 *      generation noted for ForceBoard), after every run() and every process done, and once here,
 *      after the slot's work: each module reads the forced values, as the application after the
 *      module before it (or at the slot's start) is the last thing before it (docs/forcing.md);
 *   6. account the slot's work; work longer than the basic period is a dispatcher overrun, and
 *      the next slot then starts at once (no sleep) - the grid itself never moves.
 * Before step 1, a table offered by a hot reload (reload/) takes over if this slot is due at or
 * after the offered switch time: a pointer exchange and the kept tasks' state carried over (and
 * the swap's gate arrived at: the last executor to switch does its one-time work).
 */
void Executor::loop(int64_t t0, uint64_t cycle_limit, const std::atomic<bool> &stop, stats::Counter *cycles,
                    std::atomic<int64_t> *finished_ns) {
    // The grid: slot `cycle` is due at epoch_t0 + (cycle - epoch_cycle) * basic.  A hot reload
    // re-anchors it at the swap (the new table's basic period may differ); cycle keeps counting.
    int64_t epoch_t0 = t0;
    uint64_t epoch_cycle = 0;
    int64_t basic = table_->basic_ns;
    uint64_t nslots = table_->slots.size();
    uint64_t slot_index = 0;           // (cycle - epoch_cycle) % nslots, kept from slot to slot without a division
    int64_t wake_offset = 0;           // the first wake-up's lateness: the dispatcher's Eq. (1) T0
    int64_t previous_end = INT64_MIN;  // when the last slot's work ended
    uint64_t cycle = 0;
    self_->state.store(1, std::memory_order_relaxed);
    alarm_source_ = runtime::alarmSourceWord();
    runtime::setRunAbort(&marker_.abort());  // irp::runAbortRequested() in this thread's modules
    if (options_.marker >= 0 && static_cast<std::size_t>(options_.marker) < kLifecycleMarker) {
        crash_marker_ = static_cast<std::size_t>(options_.marker);
        claimRunningMarker(crash_marker_, options_.name.c_str());
    }

    while ((cycle_limit == 0 || cycle < cycle_limit) && !stop.load(std::memory_order_relaxed)) {
        int64_t due = epoch_t0 + static_cast<int64_t>(cycle - epoch_cycle) * basic;
        if (const Table *next = next_.load(std::memory_order_acquire)) {
            const int64_t at = next_at_.load(std::memory_order_relaxed);
            if (due >= at && next_.compare_exchange_strong(next, nullptr, std::memory_order_acq_rel)) {
                // Hot reload at a macro-period boundary: the new table's slot 0 is due at `at`.
                // If late slots were skipped past it, continue with the new table's slot due now.
                const int64_t behind = due - at;
                const auto k = static_cast<uint64_t>((behind + next->basic_ns - 1) / next->basic_ns);
                takeOver(next);
                epoch_t0 = at;
                epoch_cycle = cycle - k;
                slot_index = k % next->slots.size();
                basic = next->basic_ns;
                nslots = next->slots.size();
                due = epoch_t0 + static_cast<int64_t>(k) * basic;
                switched_cycle_.store(cycle, std::memory_order_relaxed);
                switched_due_.store(due, std::memory_order_relaxed);
                switched_.store(true, std::memory_order_release);
            }
        }
        if (options_.forces) {
            // This slot's force table; an older one may be freed once every executor moved on.
            forces_ = options_.forces->current();
            force_seen_.store(forces_->generation, std::memory_order_release);
            force();  // before the slot's first module (or its release made ahead) reads them
        }
        const auto max_backlog = static_cast<uint64_t>(options_.max_catchup_ns / basic);
        int64_t woke;
        const bool slept = previous_end < due;
        // A slot led by a process that is released ahead (control.h): resolved at the wake-up.
        enum class First : uint8_t { None, Released, NotReady } first = First::None;
        int64_t first_start = 0, first_end = 0;
        if (slept) {
            Task *armed = nullptr;
            uint32_t served = 0;
            if (!table_->slots[slot_index].empty() && armAhead(table_->slots[slot_index], cycle, due)) {
                armed = table_->slots[slot_index].front();
                served = std::atomic_ref<uint32_t>(armed->config.process->release_seq).load() - 1;
            } else {
                clock_.sleepUntil(due);
            }
            woke = clock_.now();
            if (armed && resolveArmed(*armed, woke, first_start) != Armed::TakenBack) {
                // This thread was woken by the process's report (or at the end of its wait): its own
                // wake-up is taken as the process's start, which its timer made at the due time.
                woke = std::min(woke, first_start);
                if (!awaitDone(*armed->config.process, served, clock_.now(),
                               waitBound(armed->config, due, due + basic)))
                    stats::bump(armed->config.stats->overruns);
                force();
                first = First::Released;
                first_end = clock_.now();
            }
        } else {
            // Already past due when the previous slot ended: started at once, without sleeping.
            woke = previous_end;
        }
        const int64_t late = woke - due;
        if (cycle == 0) wake_offset = late;
        if (late >= basic && first == First::None) {            // (a slot whose process already ran is run)
            auto behind = static_cast<uint64_t>(late / basic);  // whole slots already past due
            if (options_.policy == OverrunPolicy::Skip || behind > max_backlog) {
                if (cycle_limit && cycle + behind >= cycle_limit) behind = cycle_limit - cycle - 1;
                skip(cycle - epoch_cycle, behind);
                cycle += behind;
                due += static_cast<int64_t>(behind) * basic;
                slot_index = (cycle - epoch_cycle) % nslots;
            }
        }
        const std::vector<Task *> &order = table_->slots[slot_index];
        int64_t t = woke;
        // A slot whose first module is a process releases it before anything else (unless it was
        // released ahead), and awaits it: it runs as soon as this thread blocks, and the
        // dispatcher's own figures below are taken after it (they change nothing the process
        // reads: its cycle is in its control slot).
        if (first == First::None && !order.empty() && runsNow(*order.front(), due) &&
            order.front()->config.kind == Task::Kind::Process) {
            const int64_t until = waitBound(order.front()->config, woke, due + basic);
            first = runProcess(*order.front(), cycle, due, woke, until) ? First::Released : First::NotReady;
            first_start = woke;
            first_end = clock_.now();
        }
        if (slept) {
            // A real wake-up: its latency against the slot it slept for, a miss if a whole period late.
            self_->latency.record(static_cast<uint64_t>(late > 0 ? late : 0));
            if (late >= basic) stats::bump(self_->missed);
        } else {
            stats::bump(self_->caught_up);
        }
        self_->jitter.record(due + wake_offset - woke);
        runtime::setCycle({cycle, static_cast<uint32_t>(slot_index), due, basic});

        for (Task *task : order) {
            const TaskConfig &c = task->config;
            TaskState &s = task->state;
            const bool released_first = first != First::None && task == order.front();
            if (!released_first) {
                if (halted()) break;  // a fault stopped the set: nothing runs any more
                if (s.disabled) {
                    serveCalls(*task, cycle);  // answers "owner disabled" to processes calling its functions
                    continue;
                }
                if (s.skip_until > due || (c.gate && !c.gate->isOpen())) {
                    // on_overrun=skip: a run due while its last one overran; or before its swap's gate opened
                    stats::bump(c.stats->skipped);
                    continue;
                }
            }
            stats::TimingRecord &r = *c.stats;
            const int64_t start = released_first ? first_start : t;
            if (c.kind == Task::Kind::Process) {
                // Released and awaited in its place, so R6's order holds across threads and processes.
                if (released_first ? first == First::NotReady
                                   : !runProcess(*task, cycle, due, start, waitBound(c, start, due + basic))) {
                    stats::bump(r.missed);  // not ready: starting, restarting, or still in its last period
                    t = clock_.now();
                    continue;
                }
            }
            if (!s.started) {
                s.started = true;
                s.t0 = start;
                s.first_due = s.run_due = due;
            }
            const int64_t jitter = s.t0 + (runDue(s, due, c.period_ns) - s.first_due) - start;  // Eq. (1)
            if (start - due >= c.period_ns) stats::bump(r.missed);
            const bool watched = c.kind == Task::Kind::Thread && c.on_overrun != config::OverrunAction::None;
            uint64_t run = 0;
            if (watched) run = marker_.begin(&r, c.on_overrun, c.overrun_limit_ns, start);
            if (c.kind == Task::Kind::Thread) {
                markRunning(crash_marker_, r.name);  // for the crash handler: one relaxed store
                runThread(*task, r);
            }
            if (watched) marker_.end();
            serveCalls(*task, cycle);  // within the owner's period, counted in its exec time
            t = released_first ? first_end : clock_.now();
            const int64_t exec = t - start;
            using S = stats::RunSample;
            post(r, S::kJitter | S::kLatency | S::kExec | S::kRun, jitter,
                 static_cast<uint64_t>(start - due > 0 ? start - due : 0), static_cast<uint64_t>(exec));
            const bool over_limit = watched && exec > c.overrun_limit_ns;
            if (over_limit || (c.kind == Task::Kind::Thread && c.budget_ns && exec > c.budget_ns))
                stats::bump(r.overruns);
            if (over_limit) overran(*task, r, run, start, t);
        }
        if (!table_->events.empty() && !halted()) t = handleEvents(cycle, due, t);
        force();  // after the slot: also over what a sporadic process in flight wrote
        markRunning(crash_marker_, nullptr);
        if (options_.trace) {
            options_.trace->sample(due);  // the traced variables, one row per basic period
            t = clock_.now();
        }
        previous_end = t;
        self_->exec.record(static_cast<uint64_t>(t - woke));
        if (t - woke > basic) stats::bump(self_->overruns);  // the work itself outgrew the period
        stats::bump(self_->runs);
        if (cycles) stats::bump(*cycles);
        ++cycle;
        if (++slot_index == nslots) slot_index = 0;
    }
    runtime::setCycle({});
    runtime::setAlarmSource(runtime::kNoAlarmSource);
    runtime::setRunAbort(nullptr);
    if (crash_marker_ < kMaxMarkedExecutors) g_running_markers[crash_marker_].tid.store(0, std::memory_order_relaxed);
    crash_marker_ = SIZE_MAX;
    forces_ = nullptr;
    force_seen_.store(UINT64_MAX, std::memory_order_release);  // reads no force table any more
    foldStats();  // off the RT path now: the figures are complete when the loop returns
    if (finished_ns)
        finished_ns->store(previous_end == INT64_MIN ? clock_.now() : previous_end, std::memory_order_relaxed);
    self_->state.store(0, std::memory_order_relaxed);
}

}  // namespace irp::dispatch
