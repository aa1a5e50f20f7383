// progress.cpp -- the dispatchers' progress as the main thread sees it; see progress.hpp.
#include "irpd/watch/progress.hpp"

#include "osal/clock.hpp"

#include <algorithm>
#include <ctime>

namespace irp::watch {

std::vector<uint64_t> dispatcherProgress(const stats::StatsSegment &segment, const reload::Generation &g) {
    std::vector<uint64_t> progress;
    for (std::size_t r : g.tables->records) progress.push_back(segment.record(r).runs.load(std::memory_order_relaxed));
    return progress;
}

std::vector<int64_t> progressWindows(const reload::Generation &g, int64_t tick_ns) {
    std::vector<int64_t> windows;
    for (const dispatch::Table &table : g.tables->executors) windows.push_back(2 * table.basic_ns + 2 * tick_ns);
    return windows;
}

bool awaitFirstSlots(const stats::StatsSegment &segment, const reload::Generation &g, int64_t limit_ns) {
    const int64_t end = osal::monotonicNow() + limit_ns;
    for (;;) {
        const std::vector<uint64_t> progress = dispatcherProgress(segment, g);
        if (std::all_of(progress.begin(), progress.end(), [](uint64_t runs) { return runs > 0; })) return true;
        if (osal::monotonicNow() > end) return false;
        const timespec pause{0, 1'000'000};
        nanosleep(&pause, nullptr);
    }
}

std::string statusLine(const reload::Generation &g, bool realtime) {
    return "running " + g.set.xml_path.string() + " (generation " + std::to_string(g.number) + ", " +
           std::to_string(g.set.modules.size() - g.disabled.size()) + " of " + std::to_string(g.set.modules.size()) +
           " modules enabled, " + (realtime ? "real-time" : "NOT real-time") + ")";
}

}  // namespace irp::watch
