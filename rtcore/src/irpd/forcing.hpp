// forcing.hpp -- the forces of the running set (docs/forcing.md), on irpd's control thread (force,
// unforce, forces, and the refusal of a write to a forced variable) and its main thread (a hot
// swap's layout): the entries with who forced what and when, resolved in the running layout, and
// published to the dispatchers as an immutable table (dispatch/forces.hpp).  irpd starts with none.
#pragma once

#include "dispatch/forces.hpp"
#include "events/event_log.hpp"
#include "variables/variable_write.hpp"

#include <indurop/result.hpp>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

namespace irp::daemon {

class Forcing {
public:
    // seen: the oldest force table generation an executor may still read (Dispatcher::forcesSeen).
    Forcing(dispatch::ForceBoard &board, events::EventLog &events, std::function<uint64_t()> seen)
        : board_(board), events_(events), seen_(std::move(seen)) {}

    // layout: the running layout.json, parsed.  The entry (#/shapes/force of protocol/control.json).
    Result<nlohmann::ordered_json> force(const nlohmann::json &layout, const std::string &path,
                                         const nlohmann::json &value, const std::string &by);
    // {"force", "left", "restored"}; an Error with code not_found when `path` is not forced.
    Result<nlohmann::ordered_json> unforce(const std::string &path, bool restore);
    // {"forces": [...], "max_forces"}
    nlohmann::ordered_json list() const;
    std::size_t count() const;
    // Why a write of `path` is refused ("" when it is not forced).
    std::string refusal(const std::string &path) const;
    // A hot swap took over with `layout` (its text): each force resolved again by its path; one
    // whose variable is gone, or whose value no longer fits its new type, is dropped (an event).
    void relayout(const std::string &layout_text);

private:
    struct Entry {
        variables::Leaf leaf;
        variables::LeafBytes value{}, before{};
        std::string by;
        int64_t since_ns = 0;
    };
    static nlohmann::ordered_json toJson(const Entry &e);
    static dispatch::ForcedLeaf placeOf(const Entry &e);
    // entries_ as the next table (mutex_ held); waits until every executor took it when `settle`.
    void publish(bool settle);
    Entry *find(const std::string &path);

    dispatch::ForceBoard &board_;
    events::EventLog &events_;
    std::function<uint64_t()> seen_;
    mutable std::mutex mutex_;
    std::vector<Entry> entries_;  // in the order they were set
};

}  // namespace irp::daemon
