// watchdog.cpp -- run markers, the outcome ring and the watchdog thread (see watchdog.hpp).
#include "dispatch/watchdog.hpp"

#include "dispatch/executor.hpp"
#include "osal/rt.hpp"

#include <algorithm>
#include <cstdio>

namespace irp::dispatch {
namespace {

std::string ms(int64_t ns) {
    char text[32];
    std::snprintf(text, sizeof text, "%.3f ms", static_cast<double>(ns) / 1e6);
    return text;
}

constexpr int64_t kIdleNs = 20'000'000;      // no watched module anywhere: only drain the rings
constexpr int64_t kMinIntervalNs = 100'000;  // the shortest look interval

}  // namespace

std::string Fault::describe() const {
    const std::string what = "on_overrun=" + std::string(config::toString(action));
    if (kind == Kind::Running) {
        std::string text = "run() still running after " + ms(elapsed_ns) + ", past its overrun limit " + ms(limit_ns) +
                           " (" + what + ", executor " + executor + ")";
        if (action == config::OverrunAction::Stop) text += ": set stopped, outputs driven to safe values";
        if (asksToEnd(action)) text += "; its run is asked to end (irp::runAbortRequested)";
        return text;
    }
    std::string text = "run() took " + ms(elapsed_ns) + ", past its overrun limit " + ms(limit_ns) + " (" + what + ")";
    switch (action) {
    case config::OverrunAction::Skip: return text + ": the runs it missed are skipped";
    case config::OverrunAction::Disable: return text + ": disabled (enable it to run it again)";
    case config::OverrunAction::Stop:
        return text + (seen_running ? ": it returned; the set stays stopped" : ": set stopped");
    default: return text;
    }
}

uint64_t RunMarker::begin(const stats::TimingRecord *record, config::OverrunAction action, int64_t limit_ns,
                          int64_t started_ns) noexcept {
    const uint64_t seq = abort_.run.load(std::memory_order_relaxed);  // even: no run in progress
    record_.store(record, std::memory_order_relaxed);
    action_.store(static_cast<uint8_t>(action), std::memory_order_relaxed);
    limit_ns_.store(limit_ns, std::memory_order_relaxed);
    started_ns_.store(started_ns, std::memory_order_relaxed);
    abort_.run.store(seq + 1, std::memory_order_release);
    return seq + 1;
}

void RunMarker::end() noexcept {
    abort_.run.store(abort_.run.load(std::memory_order_relaxed) + 1, std::memory_order_release);
}

bool RunMarker::running(Running &out) const noexcept {
    const uint64_t seq = abort_.run.load(std::memory_order_acquire);
    if (seq % 2 == 0) return false;
    out.run = seq;
    out.record = record_.load(std::memory_order_relaxed);
    out.action = static_cast<config::OverrunAction>(action_.load(std::memory_order_relaxed));
    out.limit_ns = limit_ns_.load(std::memory_order_relaxed);
    out.started_ns = started_ns_.load(std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_acquire);
    return abort_.run.load(std::memory_order_relaxed) == seq;  // the fields did not change under us
}

void RunMarker::post(const Fault &fault) noexcept {
    const uint64_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_.load(std::memory_order_acquire) >= kRing) {
        dropped_.fetch_add(1, std::memory_order_relaxed);
        return;
    }
    ring_[head % kRing] = fault;
    head_.store(head + 1, std::memory_order_release);
}

bool RunMarker::take(Fault &out) noexcept {
    const uint64_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    out = ring_[tail % kRing];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
}

Watchdog::Watchdog(osal::Clock &clock, Executors executors, std::atomic<bool> &halted, Hooks hooks)
    : clock_(clock), executors_(std::move(executors)), halted_(halted), hooks_(std::move(hooks)) {}

Watchdog::Watchdog(osal::Clock &clock, std::vector<Executor *> executors, std::atomic<bool> &halted, Hooks hooks)
    : Watchdog(clock,
               Executors{[] { return uint64_t{0}; },
                         [executors] {
                             std::vector<std::shared_ptr<Executor>> all;
                             for (Executor *e : executors) all.emplace_back(e, [](Executor *) {});  // not owned
                             return all;
                         }},
               halted, std::move(hooks)) {}

Watchdog::~Watchdog() { stop(); }

int64_t Watchdog::check(int64_t now) {
    int64_t next = now + kIdleNs;
    if (const uint64_t version = executors_.version(); version != watched_version_) {  // a hot reload changed them
        watched_ = executors_.list();
        watched_version_ = version;
        std::erase_if(reported_, [&](const auto &entry) {
            return std::none_of(watched_.begin(), watched_.end(),
                                [&](const auto &e) { return e.get() == entry.first; });
        });
    }
    for (const std::shared_ptr<Executor> &watched : watched_) {
        Executor &e = *watched;
        RunMarker &marker = e.marker();
        if (e.watching()) next = std::min(next, now + std::clamp<int64_t>(e.basicNs(), kMinIntervalNs, kIdleNs));
        RunMarker::Running r;
        if (marker.running(r)) {
            const int64_t deadline = r.started_ns + r.limit_ns;
            if (now <= deadline) {
                next = std::min(next, deadline + 1);
            } else if (reported_[&e] != r.run) {
                reported_[&e] = r.run;
                marker.markSeen(r.run);
                Fault f;
                f.kind = Fault::Kind::Running;
                f.action = r.action;
                f.record = r.record;
                f.executor = e.options().name.c_str();
                f.started_ns = r.started_ns;
                f.limit_ns = r.limit_ns;
                f.elapsed_ns = now - r.started_ns;
                f.seen_ns = now;
                if (f.action == config::OverrunAction::Stop) stopSet(f);  // the outputs first
                if (asksToEnd(f.action)) marker.requestAbort(r.run);
                if (hooks_.report) hooks_.report(f);
            }
        }
        Fault f;
        while (marker.take(f)) {
            if (f.action == config::OverrunAction::Stop) stopSet(f);  // once: a no-op when already stopped
            if (hooks_.report) hooks_.report(f);
        }
    }
    return next;
}

void Watchdog::stopSet(const Fault &fault) {
    {
        std::lock_guard lock(mutex_);
        if (stopped_) return;
        stopped_ = true;
        halted_.store(true, std::memory_order_relaxed);
        stopped_by_ = "module '" + fault.module() + "': " + fault.describe();
    }
    // A process released ahead for a slot that will not run now must not run it either.
    for (const std::shared_ptr<Executor> &e : executors_.list()) e->cancelArmed();
    if (hooks_.stop) hooks_.stop(fault);
}

std::string Watchdog::stoppedBy() const {
    std::lock_guard lock(mutex_);
    return stopped_by_;
}

void Watchdog::start(int rt_priority) {
    thread_ = std::thread([this, rt_priority] {
        if (rt_priority > 0) osal::makeCurrentThreadRealtime(rt_priority, -1);
        while (!quit_.load(std::memory_order_relaxed)) clock_.sleepUntil(check(clock_.now()));
    });
}

void Watchdog::stop() {
    quit_.store(true, std::memory_order_relaxed);
    if (thread_.joinable()) thread_.join();
}

}  // namespace irp::dispatch
