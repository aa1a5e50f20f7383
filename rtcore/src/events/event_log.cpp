// event_log.cpp -- the ring of events and its JSON.
#include "events/event_log.hpp"

#include <ctime>

namespace irp::events {

std::string isoTime(int64_t ns) {
    const time_t seconds = static_cast<time_t>(ns / 1'000'000'000);
    tm utc{};
    gmtime_r(&seconds, &utc);
    char text[64];
    const std::size_t n = std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%S", &utc);
    std::snprintf(text + n, sizeof text - n, ".%06lldZ", static_cast<long long>((ns % 1'000'000'000) / 1000));
    return text;
}

uint64_t EventLog::add(std::string kind, std::string module, std::string message) {
    timespec now{};
    clock_gettime(CLOCK_REALTIME, &now);
    std::lock_guard lock(mutex_);
    Event e{next_seq_++, static_cast<int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec, std::move(kind),
            std::move(module), std::move(message)};
    events_.push_back(std::move(e));
    if (events_.size() > kCapacity) events_.pop_front();
    return next_seq_ - 1;
}

uint64_t EventLog::last() const {
    std::lock_guard lock(mutex_);
    return next_seq_ - 1;
}

nlohmann::ordered_json EventLog::since(uint64_t since, std::size_t limit) const {
    using json = nlohmann::ordered_json;
    std::lock_guard lock(mutex_);
    json list = json::array();
    const uint64_t oldest = events_.empty() ? next_seq_ : events_.front().seq;
    uint64_t next = since;
    for (const Event &e : events_) {
        if (e.seq <= since) continue;
        if (list.size() >= limit) break;
        list.push_back({{"seq", e.seq},
                        {"time", isoTime(e.time_ns)},
                        {"time_ns", e.time_ns},
                        {"kind", e.kind},
                        {"module", e.module.empty() ? json(nullptr) : json(e.module)},
                        {"message", e.message}});
        next = e.seq;
    }
    return json{{"next", next}, {"dropped", oldest > since + 1 ? oldest - since - 1 : 0}, {"events", std::move(list)}};
}

}  // namespace irp::events
