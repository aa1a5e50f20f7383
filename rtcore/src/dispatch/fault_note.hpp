// fault_note.hpp -- what a thread module threw out of run() or condition(), kept for its `fault`
// event (docs/faults.md): its executor writes the text on the RT thread (fixed buffer, no
// allocation, no lock), irpd's main thread reads it when it turns the module's new `errors` count
// into the event.  A seqlock: `seq` is odd while the text is written.
#pragma once

#include <atomic>
#include <cstdio>
#include <string>

namespace irp::dispatch {

class FaultNote {
public:
    // Executor thread: "<what>: <detail>", e.g. "run(): main.st:12:9: division by zero", cut to fit.
    void note(const char *what, const char *detail) noexcept {
        const uint64_t seq = seq_.load(std::memory_order_relaxed);
        seq_.store(seq + 1, std::memory_order_relaxed);
        std::atomic_thread_fence(std::memory_order_release);
        std::snprintf(text_, sizeof text_, "%s: %s", what, detail);
        seq_.store(seq + 2, std::memory_order_release);
    }
    // Any thread: the last text noted, "" if none (or while a new one is being written).
    std::string read() const {
        for (int attempt = 0; attempt < 3; ++attempt) {
            const uint64_t seq = seq_.load(std::memory_order_acquire);
            if (seq % 2) continue;
            std::string text(text_);
            std::atomic_thread_fence(std::memory_order_acquire);
            if (seq_.load(std::memory_order_relaxed) == seq) return text;
        }
        return "";
    }

private:
    std::atomic<uint64_t> seq_{0};
    char text_[512] = {};
};

}  // namespace irp::dispatch
