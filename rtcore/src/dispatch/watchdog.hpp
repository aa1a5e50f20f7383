// watchdog.hpp -- the per-module overrun watchdog (a PLC task watchdog): <on_overrun> and
// <overrun_limit> of module.xml, docs/faults.md.
//
// A thread module runs on its executor's RT thread, so a run that never ends can only be seen
// from another thread.  Each executor keeps a RunMarker: before a watched module's run() it
// stores the start time, the limit and the action (a seqlock of relaxed atomics: no syscall, no
// lock on the RT thread); the Watchdog thread reads the markers and acts on a run that is still
// going past its limit.  After a run the executor applies warn / skip / disable / stop itself (it
// alone owns its tasks) and posts the outcome into a small lock-free ring that the Watchdog turns
// into events.  Executor::loop is the only writer of a marker and of its ring.
#pragma once

#include "config/module_xml.hpp"
#include "osal/clock.hpp"
#include "sdk/runtime.hpp"
#include "stats/stats_block.hpp"

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace irp::dispatch {

class Executor;

// Whether the watchdog asks a run past its limit to end (irp::runAbortRequested() true in it):
// for the actions that take the module out anyway, `disable` and `stop`; `warn` and `skip` let
// the run go on.
constexpr bool asksToEnd(config::OverrunAction action) {
    return action == config::OverrunAction::Disable || action == config::OverrunAction::Stop;
}

// What the watchdog saw or what an executor did about one overrun.
struct Fault {
    enum class Kind : uint8_t {
        Running,   // the watchdog: a run still going past its limit (detected while it runs)
        Returned,  // the executor: a run that ended past its limit, and the action it took
    };
    Kind kind = Kind::Running;
    config::OverrunAction action = config::OverrunAction::None;
    const stats::TimingRecord *record = nullptr;  // the module (its name); lives as long as irpd
    const char *executor = "";
    int64_t started_ns = 0;  // CLOCK_MONOTONIC start of the run
    int64_t limit_ns = 0;
    int64_t elapsed_ns = 0;     // Running: how long it had run when seen; Returned: its execution time
    int64_t seen_ns = 0;        // when the watchdog saw it (Running) or the run ended (Returned)
    bool seen_running = false;  // Returned: the watchdog had already reported this run

    std::string module() const { return record ? record->name : ""; }
    // One line for the event log: what happened and what was done.
    std::string describe() const;
};

// One executor's watched run in progress, and the ring of outcomes it posts.
class RunMarker {
public:
    // Executor thread (RT): around a watched module's run().  begin() returns the run's number.
    uint64_t begin(const stats::TimingRecord *record, config::OverrunAction action, int64_t limit_ns,
                   int64_t started_ns) noexcept;
    void end() noexcept;
    // Executor thread: whether the watchdog reported run `run` while it ran.
    bool seen(uint64_t run) const noexcept { return seen_.load(std::memory_order_acquire) == run; }
    // Executor thread: posts an outcome (dropped and counted when the ring is full).
    void post(const Fault &fault) noexcept;
    // The request irp::runAbortRequested() reads on the executor's thread (runtime::setRunAbort).
    const runtime::RunAbort &abort() const noexcept { return abort_; }

    // Watchdog thread: the run in progress, if any (a consistent copy); marks it seen.
    struct Running {
        uint64_t run = 0;
        const stats::TimingRecord *record = nullptr;
        config::OverrunAction action = config::OverrunAction::None;
        int64_t limit_ns = 0, started_ns = 0;
    };
    bool running(Running &out) const noexcept;
    void markSeen(uint64_t run) noexcept { seen_.store(run, std::memory_order_release); }
    // Watchdog thread: asks run `run` to end (irp::runAbortRequested() turns true in it).
    void requestAbort(uint64_t run) noexcept { abort_.requested.store(run, std::memory_order_relaxed); }
    // Watchdog thread: the next posted outcome.
    bool take(Fault &out) noexcept;
    uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }

private:
    // abort_.run is the seqlock's sequence: odd while a watched run is in progress; the fields
    // below change only while it is even.  abort_.requested: the run the watchdog asked to end.
    runtime::RunAbort abort_;
    std::atomic<const stats::TimingRecord *> record_{nullptr};
    std::atomic<uint8_t> action_{0};
    std::atomic<int64_t> limit_ns_{0}, started_ns_{0};
    std::atomic<uint64_t> seen_{0};
    // single-producer (executor), single-consumer (watchdog) ring of outcomes
    static constexpr std::size_t kRing = 32;
    std::array<Fault, kRing> ring_{};
    std::atomic<uint64_t> head_{0}, tail_{0}, dropped_{0};
};

class Watchdog {
public:
    struct Hooks {
        // every detection and every outcome, for the event log (watchdog thread)
        std::function<void(const Fault &)> report;
        // the set was stopped by a fault: drive the outputs to safe values (watchdog thread,
        // called once, at once, while the faulty module may still be running)
        std::function<void(const Fault &)> stop;
    };

    // The executors to watch (a hot reload adds and removes them): `version` changes whenever the
    // list does, and is asked at every look; `list` only then.  Each pointer keeps its executor
    // alive while the watchdog holds it.
    struct Executors {
        std::function<uint64_t()> version;
        std::function<std::vector<std::shared_ptr<Executor>>()> list;
    };

    // Watches the markers of `executors`; `halted` is the flag every executor checks (the dispatcher's).
    Watchdog(osal::Clock &clock, Executors executors, std::atomic<bool> &halted, Hooks hooks);
    // The same for a fixed list (not owned: they outlive the watchdog).
    Watchdog(osal::Clock &clock, std::vector<Executor *> executors, std::atomic<bool> &halted, Hooks hooks);
    ~Watchdog();
    Watchdog(const Watchdog &) = delete;
    Watchdog &operator=(const Watchdog &) = delete;

    // One look at every executor (tests call it directly): reports runs past their limit, takes
    // the stop action, drains the outcomes.  Returns when it wants to look again.
    int64_t check(int64_t now);

    // The watchdog thread: SCHED_FIFO at rt_priority (0: SCHED_OTHER), not pinned (irpd keeps
    // its non-RT threads off the dispatchers' CPUs).  Sleeps until the earliest limit of a run
    // in progress, else one idle interval.
    void start(int rt_priority);
    void stop();

    // Once a fault stopped the set: why (for `status`), "" before.
    std::string stoppedBy() const;
    // Stops the set for a fault found elsewhere (a process module that hangs): halts every
    // executor, runs the stop hook, remembers why.  Once; later calls do nothing.
    void stopSet(const Fault &fault);

private:
    osal::Clock &clock_;
    Executors executors_;
    std::atomic<bool> &halted_;
    Hooks hooks_;
    mutable std::mutex mutex_;
    std::atomic<bool> quit_{false};
    std::string stopped_by_;
    bool stopped_ = false;
    std::map<const Executor *, uint64_t> reported_;   // per executor: the last run reported as running
    std::vector<std::shared_ptr<Executor>> watched_;  // executors_.list() as of watched_version_
    std::optional<uint64_t> watched_version_;
    std::thread thread_;
};

}  // namespace irp::dispatch
