// main_queue.hpp -- work the control thread hands to irpd's main thread.
//
// Hot reloads start and stop processes, and the process supervisor must be used from the thread
// that outlives the children (irpd's main thread: PR_SET_PDEATHSIG is per thread).  The control
// thread posts such a command here and waits for its result; the main thread runs what is posted
// between its 20 ms ticks.  One job runs at a time, in posting order.
#pragma once

#include <indurop/result.hpp>

#include <nlohmann/json.hpp>

#include <chrono>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>

namespace irp::daemon {

class MainQueue {
public:
    using Answer = Result<nlohmann::ordered_json>;

    // From the control thread: runs job on the main thread; waits at most `timeout` for it.
    Answer call(std::function<Answer()> job, std::chrono::milliseconds timeout) {
        auto promise = std::make_shared<std::promise<Answer>>();
        auto future = promise->get_future();
        {
            std::lock_guard lock(mutex_);
            if (closed_) return Error{"irpd is stopping"};
            jobs_.push_back([promise, job = std::move(job)] { promise->set_value(job()); });
        }
        if (future.wait_for(timeout) != std::future_status::ready)
            return Error{"irpd's main thread did not answer within " + std::to_string(timeout.count()) +
                         " ms; the command may still complete (see the events)"};
        try {
            return future.get();
        } catch (const std::future_error &) {  // dropped by close()
            return Error{"irpd is stopping"};
        }
    }

    // True when a job waits (the main thread then stretches the watchdog before running it).
    bool pending() {
        std::lock_guard lock(mutex_);
        return !jobs_.empty();
    }

    // From the main thread: runs every posted job.
    void runPending() {
        for (;;) {
            std::function<void()> job;
            {
                std::lock_guard lock(mutex_);
                if (jobs_.empty()) return;
                job = std::move(jobs_.front());
                jobs_.pop_front();
            }
            job();
        }
    }

    // Refuses further jobs; those still queued are answered "irpd is stopping".
    void close() {
        std::deque<std::function<void()>> left;
        {
            std::lock_guard lock(mutex_);
            closed_ = true;
            left.swap(jobs_);
        }
        (void)left;  // dropping a job breaks its promise: the waiting call() returns at once
    }

private:
    std::mutex mutex_;
    std::deque<std::function<void()>> jobs_;
    bool closed_ = false;
};

}  // namespace irp::daemon
