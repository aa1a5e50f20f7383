// executor.cpp -- the RT loop.  Everything below loop()'s first line runs on a SCHED_FIFO thread:
// no allocation, no locks, no syscalls but clock_gettime (vDSO) and clock_nanosleep.
#include "dispatch/executor.hpp"

#include "sdk/runtime.hpp"

#include <exception>

namespace irp::dispatch {

const char *toString(OverrunPolicy policy) { return policy == OverrunPolicy::CatchUp ? "catch-up" : "skip"; }

Executor::Executor(osal::Clock &clock, int64_t basic_ns, std::vector<std::vector<Task *>> slots,
                   std::vector<Task *> tasks, stats::TimingRecord *self, ExecutorOptions options)
    : clock_(clock), basic_ns_(basic_ns), slots_(std::move(slots)), tasks_(std::move(tasks)), self_(self),
      options_(std::move(options)) {}

// Counts the runs that skipping slots [from, from + count) takes from each task.
void Executor::skip(uint64_t from, uint64_t count) {
    stats::bump(self_->skipped, count);
    for (Task *t : tasks_) {
        auto ps = static_cast<uint64_t>(t->period_slots);
        uint64_t due = (from + count + ps - 1) / ps - (from + ps - 1) / ps;  // multiples of ps in the range
        if (due) stats::bump(t->stats->skipped, due);
    }
}

/*
 * One iteration = one basic period:
 *   1. sleep until the slot's absolute due time T0 + n * basic (clock_nanosleep TIMER_ABSTIME),
 *      unless the previous slot ended past it (then start at once: a caught-up slot);
 *   2. account the wake-up: latency (woke - due), a miss if a whole period late; if the backlog
 *      passed what the overrun policy allows, skip slots to the current one; Eq. (1) jitter;
 *   3. run the slot's modules in priority order; for each: Eq. (1) jitter against its own T0 and
 *      period, start latency, execution time, budget overrun; a throw disables the module;
 *   4. account the slot's work; work past the next slot's due time is a dispatcher overrun, and the
 *      next slot then starts at once (no sleep) - the grid itself never moves.
 * (Sporadic modules' condition() and the event handler come after step 3 in a later version.)
 */
void Executor::loop(int64_t t0, uint64_t cycle_limit, const std::atomic<bool> &stop, stats::Counter *cycles,
                    std::atomic<int64_t> *finished_ns) {
    const auto nslots = static_cast<uint64_t>(slots_.size());
    const int64_t basic = basic_ns_;
    const auto max_backlog = static_cast<uint64_t>(options_.max_catchup_ns / basic);
    int64_t first_wake = 0;
    int64_t previous_end = INT64_MIN;  // when the last slot's work ended
    uint64_t cycle = 0;
    self_->state.store(1, std::memory_order_relaxed);

    while ((cycle_limit == 0 || cycle < cycle_limit) && !stop.load(std::memory_order_relaxed)) {
        int64_t due = t0 + static_cast<int64_t>(cycle) * basic;
        int64_t woke;
        if (previous_end < due) {
            // A real wake-up: its latency against the slot it slept for, a miss if a whole period late.
            clock_.sleepUntil(due);
            woke = clock_.now();
            const int64_t late = woke - due;
            self_->latency.record(static_cast<uint64_t>(late > 0 ? late : 0));
            if (late >= basic) stats::bump(self_->missed);
        } else {
            // Already past due when the previous slot ended: started at once, without sleeping.
            woke = previous_end;
            stats::bump(self_->caught_up);
        }
        if (cycle == 0) first_wake = woke;

        const int64_t late = woke - due;
        if (late >= basic) {
            auto behind = static_cast<uint64_t>(late / basic);  // whole slots already past due
            if (options_.policy == OverrunPolicy::Skip || behind > max_backlog) {
                if (cycle_limit && cycle + behind >= cycle_limit) behind = cycle_limit - cycle - 1;
                skip(cycle, behind);
                cycle += behind;
                due += static_cast<int64_t>(behind) * basic;
            }
        }
        self_->jitter.record(first_wake + static_cast<int64_t>(cycle) * basic - woke);

        const uint64_t slot_index = cycle % nslots;
        runtime::setCycle({cycle, static_cast<uint32_t>(slot_index), due, basic});
        int64_t t = woke;
        for (Task *task : slots_[slot_index]) {
            if (task->disabled) continue;
            const int64_t start = t;
            if (!task->started) {
                task->started = true;
                task->t0 = start;
                task->first_cycle = cycle;
            }
            const auto n = static_cast<int64_t>((cycle - task->first_cycle) / static_cast<uint64_t>(task->period_slots));
            stats::TimingRecord &r = *task->stats;
            r.jitter.record(task->t0 + n * task->period_ns - start);
            r.latency.record(static_cast<uint64_t>(start - due > 0 ? start - due : 0));
            if (start - due >= task->period_ns) stats::bump(r.missed);
            try {
                task->run();
            } catch (const std::exception &e) {
                task->disabled = true;
                stats::bump(r.errors);
                r.state.store(static_cast<uint32_t>(stats::ModuleState::Disabled), std::memory_order_relaxed);
                irp::printf("irpd: module '%s' threw from run(): %s; disabled\n", r.name, e.what());
            } catch (...) {
                task->disabled = true;
                stats::bump(r.errors);
                r.state.store(static_cast<uint32_t>(stats::ModuleState::Disabled), std::memory_order_relaxed);
                irp::printf("irpd: module '%s' threw a non-standard exception from run(); disabled\n", r.name);
            }
            t = clock_.now();
            const int64_t exec = t - start;
            r.exec.record(static_cast<uint64_t>(exec));
            if (task->budget_ns && exec > task->budget_ns) stats::bump(r.overruns);
            stats::bump(r.runs);
        }
        previous_end = t;
        self_->exec.record(static_cast<uint64_t>(t - woke));
        if (t - woke > basic) stats::bump(self_->overruns);  // the work itself outgrew the period
        stats::bump(self_->runs);
        if (cycles) stats::bump(*cycles);
        ++cycle;
    }
    runtime::setCycle({});
    if (finished_ns) finished_ns->store(previous_end == INT64_MIN ? clock_.now() : previous_end, std::memory_order_relaxed);
    self_->state.store(0, std::memory_order_relaxed);
}

} // namespace irp::dispatch
