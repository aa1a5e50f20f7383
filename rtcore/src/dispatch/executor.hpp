// executor.hpp -- one dispatcher thread's loop: a slot table walked once per basic period.
//
// The main executor runs the set's slot table (Table 3).  A module may name another executor
// (<executor> in module.xml): that executor is its own SCHED_FIFO thread, at its own priority and
// CPU, with a slot table of its own modules only, on the same time grid (same T0).  A slow module
// there can overrun without delaying the fast ones on the main executor.
#pragma once

#include "osal/clock.hpp"
#include "stats/stats_block.hpp"

#include <indurop/control.h>

#include <atomic>
#include <cstdint>
#include <string>
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

// One module's place in an executor.  Runtime fields are written by the executor thread only.
struct Task {
    enum class Kind : uint8_t { Thread, Process };
    Kind kind = Kind::Thread;
    bool sporadic = false;     // run by the event handler, not from the slot table
    void (*run)() = nullptr;   // thread modules
    int (*condition)() = nullptr;            // sporadic thread modules
    indurop_process_slot *process = nullptr; // process modules: their control slot
    int64_t deadline_ns = 0;   // sporadic: from condition true / release to completion
    stats::TimingRecord *stats = nullptr;
    int64_t period_ns = 0;
    int64_t period_slots = 1;  // period / the executor's basic period
    int64_t budget_ns = 0;     // 0 = none
    // a thread module whose exported functions process modules call: served after its run()
    CallServer *calls = nullptr;
    int module = -1;           // its index in the set (the owner in the call server's table)
    // set by the loop
    int64_t t0 = 0;            // first start (T0 of Eq. (1))
    uint64_t first_cycle = 0;
    bool started = false;
    bool disabled = false;
    // a sporadic process's release in flight
    bool in_flight = false;
    bool deadline_missed = false;
    uint32_t released_seq = 0;
    int64_t released_at = 0;
};

struct ExecutorOptions {
    std::string name = "main";
    int rt_priority = 80;
    int cpu = -1;  // -1: do not pin
    OverrunPolicy policy = OverrunPolicy::CatchUp;
    int64_t max_catchup_ns = 100'000'000;
    trace::TraceRings *trace = nullptr;  // sampled after every slot's work (the main executor's)
};

class Executor {
public:
    // slots[i]: the tasks of slot i in run order; tasks: every periodic task; events: the sporadic
    // tasks in priority order (the event handler's list).  self: this dispatcher's own record.
    Executor(osal::Clock &clock, int64_t basic_ns, std::vector<std::vector<Task *>> slots, std::vector<Task *> tasks,
             stats::TimingRecord *self, ExecutorOptions options, std::vector<Task *> events = {});

    // The RT loop.  Slot n is due at t0 + n * basic.  Returns when `stop` is set (checked every
    // slot) or after cycle_limit slots (0 = no limit).  `cycles`, if given, counts slots done;
    // `finished_ns`, if given, receives the time the last slot's work ended.
    void loop(int64_t t0, uint64_t cycle_limit, const std::atomic<bool> &stop, stats::Counter *cycles,
              std::atomic<int64_t> *finished_ns = nullptr);

    const ExecutorOptions &options() const { return options_; }
    int64_t basicNs() const { return basic_ns_; }

private:
    void skip(uint64_t from_cycle, uint64_t count);
    void runThread(Task &task, stats::TimingRecord &r);
    // Serves the calls from process modules waiting for task's functions (none without a call server).
    void serveCalls(Task &task, uint64_t cycle);
    // Releases a periodic process and waits (futex) until it reports the period done, at most
    // until `wait_until`.  False if it was not ready to be released.
    bool runProcess(Task &task, uint64_t cycle, int64_t due, int64_t start, int64_t wait_until);
    // The event handler (Figure 6): conditions of sporadic threads, then releases of sporadic processes.
    int64_t handleEvents(uint64_t cycle, int64_t due, int64_t t);
    void disable(Task &task, stats::TimingRecord &r, const char *what, const char *detail);

    osal::Clock &clock_;
    int64_t basic_ns_;
    std::vector<std::vector<Task *>> slots_;
    std::vector<Task *> tasks_;
    std::vector<Task *> events_;
    stats::TimingRecord *self_;
    ExecutorOptions options_;
};

} // namespace irp::dispatch
