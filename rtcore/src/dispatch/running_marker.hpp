// running_marker.hpp -- which module each dispatcher thread is running at this instant, for the
// crash handler (supervise/crash_record.hpp): a thread module's segfault cannot be contained,
// but irpd can say whose code it was in.  The executor keeps it with one relaxed store of a
// pointer before each thread module's run()/condition() and one after the slot; the main thread
// marks a module's initialize()/start()/stop() the same way.  Readers: the signal handler only.
#pragma once

#include <atomic>
#include <cstddef>

namespace irp::dispatch {

struct RunningMarker {
    std::atomic<const char *> module{nullptr};  // its name (stats record or module spec); null: none
    std::atomic<int> tid{0};                    // the thread's kernel id, 0 when unused
    char executor[64] = {};                     // "main", an <executor>'s name, or "lifecycle"
};

// Markers [0, kMaxMarkedExecutors - 1) belong to executors by their index; the last one to the
// main thread's calls of module lifecycle functions.
inline constexpr std::size_t kMaxMarkedExecutors = 64;
inline constexpr std::size_t kLifecycleMarker = kMaxMarkedExecutors - 1;
inline RunningMarker g_running_markers[kMaxMarkedExecutors];

// Claims marker `index` for the calling thread (not async-signal-safe; before the RT loop).
void claimRunningMarker(std::size_t index, const char *executor);
// Marks the calling thread as running `module` in marker `index` (null: nothing).
inline void markRunning(std::size_t index, const char *module) noexcept {
    if (index < kMaxMarkedExecutors) g_running_markers[index].module.store(module, std::memory_order_relaxed);
}

}  // namespace irp::dispatch
