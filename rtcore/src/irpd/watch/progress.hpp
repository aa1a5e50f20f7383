// progress.hpp -- what irpd's main thread reads of its dispatchers' progress: each one's completed
// slots (its record's `runs`, which the RT loop counts anyway), the window within which each must
// complete one to count as moving (docs/supervision.md), the wait for every first slot before
// READY=1, and the status line systemd shows.
#pragma once

#include "reload/generation.hpp"
#include "stats/stats_segment.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace irp::watch {

// Each dispatcher's completed slots, in the generation's executor order (main first): what a
// watchdog ping vouches for.
std::vector<uint64_t> dispatcherProgress(const stats::StatsSegment &segment, const reload::Generation &g);

// How long each dispatcher may go without completing a slot and still count as moving: two of
// its basic periods plus two of the main thread's ticks (it looks once per tick).
std::vector<int64_t> progressWindows(const reload::Generation &g, int64_t tick_ns);

// Waits (at most limit_ns, polling every millisecond) until every dispatcher completed a slot;
// false if one had not by then.
bool awaitFirstSlots(const stats::StatsSegment &segment, const reload::Generation &g, int64_t limit_ns);

// "running <set> (generation G, N of M modules enabled, real-time)"
std::string statusLine(const reload::Generation &g, bool realtime);

}  // namespace irp::watch
