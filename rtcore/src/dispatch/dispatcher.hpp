// dispatcher.hpp -- turns a loaded set into running executors: builds each executor's slot table
// from the schedule, starts one RT thread per executor, aligns them on one T0, stops them.
#pragma once

#include "common/result.hpp"
#include "config/module_xml.hpp"
#include "dispatch/executor.hpp"
#include "schedule/schedule.hpp"
#include "stats/stats_segment.hpp"

#include <atomic>
#include <memory>
#include <string>
#include <functional>
#include <pthread.h>
#include <vector>

namespace irp::dispatch {

struct DispatcherOptions {
    int rt_priority = 80;  // the main executor; other executors default to one below
    int cpu = -1;          // -1: the last CPU this process may use
    bool realtime = true;  // false: do not even try SCHED_FIFO (development only)
    OverrunPolicy policy = OverrunPolicy::CatchUp;
    int64_t max_catchup_ns = 100'000'000;
    trace::TraceRings *trace = nullptr;  // sampled by the main executor after every slot
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
};

struct ExecutorReport {
    std::string name;
    int cpu = -1;
    int rt_priority = 0;
    bool realtime = false;
    std::string detail;
};

class Dispatcher {
public:
    // bindings[i] belongs to set.modules[i].  Records for the executors are taken from `segment`
    // at indices 0..executors-1 (see recordsNeeded).
    Dispatcher(const config::SetSpec &set, const schedule::Schedule &schedule, std::vector<ModuleBinding> bindings,
               stats::StatsSegment &segment, DispatcherOptions options, osal::Clock &clock);
    ~Dispatcher();

    // Executors a set needs: "main" plus each <executor> of the set.
    static std::size_t executorCount(const config::SetSpec &set) { return 1 + set.executors.size(); }

    // Checks CPUs and priorities; starts the threads; returns once every thread runs (or failed
    // before its first slot).  duration_ns > 0 stops each executor after exactly that much of the
    // time grid (duration / its basic period slots).
    Status start(int64_t duration_ns);
    void requestStop() { stop_.store(true, std::memory_order_relaxed); }
    bool finished() const { return finished_threads_.load(std::memory_order_acquire) == threads_.size(); }
    // Waits for every executor thread (call requestStop() first unless a duration was given).
    void join();

    const std::vector<ExecutorReport> &reports() const { return reports_; }
    bool realtime() const;

private:
    struct Plan;
    struct StartGate;
    std::vector<std::unique_ptr<Plan>> plans_;
    std::unique_ptr<StartGate> gate_;
    std::vector<std::unique_ptr<Task>> tasks_;
    Status spawn(std::function<void()> body);
    static constexpr std::size_t kThreadStackBytes = 1u << 20;

    std::vector<pthread_t> threads_;
    std::vector<ExecutorReport> reports_;
    std::atomic<bool> stop_{false};
    std::atomic<std::size_t> finished_threads_{0};
    stats::StatsSegment &segment_;
    DispatcherOptions options_;
    osal::Clock &clock_;
};

} // namespace irp::dispatch
