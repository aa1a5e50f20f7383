// event_log.hpp -- what happened to the running set, for people: swaps, faults, deadline misses,
// process exits and restarts.  irpd's non-RT side writes it (the RT threads only count, in the
// stats block; the main thread turns new counts into events); the control protocol's `events`
// command reads it.  In memory, the last kCapacity events, numbered from 1.
#pragma once

#include "protocol/limits.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <deque>
#include <mutex>
#include <string>

namespace irp::events {

struct Event {
    uint64_t seq = 0;
    int64_t time_ns = 0;  // CLOCK_REALTIME
    std::string kind;     // start, stop, swap, swap_failed, fault, deadline, overrun, stopped, safe_outputs_failed,
                          // process_exit, process_restart, process_hang, process_output_dropped
    std::string module;   // "" = the set as a whole
    std::string message;
};

class EventLog {
public:
    static constexpr auto kCapacity = static_cast<std::size_t>(protocol::kEventLogCapacity);  // protocol/control.json

    // Adds an event (also written to irpd's log as one line by the caller if it wants).
    uint64_t add(std::string kind, std::string module, std::string message);

    // {"next", "dropped", "events": [...]}: events with seq > since, at most limit of them;
    // dropped = how many after `since` are gone (older than the ring keeps).
    nlohmann::ordered_json since(uint64_t since, std::size_t limit) const;

    uint64_t last() const;

private:
    mutable std::mutex mutex_;
    std::deque<Event> events_;
    uint64_t next_seq_ = 1;
};

// "2026-11-22T10:15:02.123456Z"
std::string isoTime(int64_t realtime_ns);

}  // namespace irp::events
