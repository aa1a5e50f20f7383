// forcing.cpp -- force entries, their tables for the dispatchers, and their events.
#include "irpd/forcing.hpp"

#include "osal/clock.hpp"
#include "protocol/errors.hpp"
#include "protocol/limits.hpp"

#include <chrono>
#include <cstring>
#include <thread>

namespace irp::daemon {
namespace {

using json = nlohmann::ordered_json;

int64_t realtimeNow() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
        .count();
}

// How long an unforce waits for every executor to take the table without the force before it
// restores the value (an executor takes it at its next slot; a stuck one is not waited for).
constexpr auto kSettleLimit = std::chrono::seconds(1);

}  // namespace

json Forcing::toJson(const Entry &e) {
    return json{{"path", e.leaf.path},
                {"value", variables::decodeValue(e.leaf, e.value)},
                {"before", variables::decodeValue(e.leaf, e.before)},
                {"by", e.by},
                {"since_ns", e.since_ns},
                {"type", e.leaf.type}};
}

dispatch::ForcedLeaf Forcing::placeOf(const Entry &e) {
    dispatch::ForcedLeaf f;
    f.offset = e.leaf.offset;
    f.size = e.leaf.size;
    f.lock = e.leaf.lock;
    std::memcpy(f.value, e.value.data(), sizeof f.value);
    return f;
}

Forcing::Entry *Forcing::find(const std::string &path) {
    for (Entry &e : entries_)
        if (e.leaf.path == path) return &e;
    return nullptr;
}

void Forcing::publish(bool settle) {
    std::vector<dispatch::ForcedLeaf> leaves;
    leaves.reserve(entries_.size());
    for (const Entry &e : entries_) leaves.push_back(placeOf(e));
    const uint64_t generation = board_.publish(std::move(leaves));
    const auto give_up = std::chrono::steady_clock::now() + kSettleLimit;
    while (settle && seen_() < generation && std::chrono::steady_clock::now() < give_up)
        std::this_thread::sleep_for(std::chrono::microseconds(50));
    board_.reclaim(seen_());
}

Result<json> Forcing::force(const nlohmann::json &layout, const std::string &path, const nlohmann::json &value,
                            const std::string &by) {
    auto leaf = variables::findLeaf(layout, path);
    if (!leaf) return Error{"cannot force: " + leaf.error().message};
    auto bytes = variables::encodeValue(*leaf, value);
    if (!bytes) return Error{"cannot force: " + bytes.error().message};
    std::lock_guard lock(mutex_);
    Entry *entry = find(path);
    if (!entry) {
        if (entries_.size() >= static_cast<std::size_t>(protocol::kMaxForces))
            return Error{"cannot force '" + path + "': " + std::to_string(entries_.size()) +
                         " variables are forced, the most there may be (max_forces); unforce one first"};
        Entry e;
        e.leaf = *leaf;
        e.before = variables::readLeaf(*leaf);
        entries_.push_back(std::move(e));
        entry = &entries_.back();
    }
    entry->value = *bytes;
    entry->by = by;
    entry->since_ns = realtimeNow();
    publish(false);
    dispatch::applyForce(placeOf(*entry));  // at once, not only at the next module
    const json answer = toJson(*entry);
    events_.add("force_set", "", "'" + path + "' forced to " + answer["value"].dump() + " by " + by);
    return answer;
}

Result<json> Forcing::unforce(const std::string &path, bool restore) {
    std::lock_guard lock(mutex_);
    Entry *entry = find(path);
    if (!entry) {
        std::string forced;
        for (const Entry &e : entries_) forced += (forced.empty() ? "" : ", ") + e.leaf.path;
        return Error{"'" + path + "' is not forced (forced: " + (forced.empty() ? "none" : forced) + ")",
                     protocol::kNotFound};
    }
    const Entry removed = *entry;
    entries_.erase(entries_.begin() + (entry - entries_.data()));
    // Every executor must have let go of the force before the old value is written back.
    publish(true);
    if (restore)
        if (Status st = variables::writeLeaf(removed.leaf, removed.before); !st) return st.error();
    const json left = variables::decodeValue(removed.leaf, variables::readLeaf(removed.leaf));
    events_.add("force_cleared", "",
                "'" + path + "' no longer forced (forced by " + removed.by + "), " +
                    (restore ? "restored to " : "left at ") + left.dump());
    return json{{"force", toJson(removed)}, {"left", left}, {"restored", restore}};
}

json Forcing::list() const {
    std::lock_guard lock(mutex_);
    json forces = json::array();
    for (const Entry &e : entries_) forces.push_back(toJson(e));
    return json{{"forces", std::move(forces)}, {"max_forces", protocol::kMaxForces}};
}

std::size_t Forcing::count() const {
    std::lock_guard lock(mutex_);
    return entries_.size();
}

std::string Forcing::refusal(const std::string &path) const {
    std::lock_guard lock(mutex_);
    for (const Entry &e : entries_)
        if (e.leaf.path == path)
            return "'" + path + "' is forced by " + e.by + " (to " + variables::decodeValue(e.leaf, e.value).dump() +
                   "): a write would be undone by the force; unforce it first (irpctl unforce " + path + ")";
    return {};
}

void Forcing::relayout(const std::string &layout_text) {
    const nlohmann::json layout = nlohmann::json::parse(layout_text, nullptr, false);
    std::lock_guard lock(mutex_);
    if (entries_.empty()) return;
    std::vector<Entry> kept;
    for (Entry &e : entries_) {
        const json value = variables::decodeValue(e.leaf, e.value), before = variables::decodeValue(e.leaf, e.before);
        auto leaf = variables::findLeaf(layout, e.leaf.path);
        auto bytes = leaf ? variables::encodeValue(*leaf, value) : Result<variables::LeafBytes>(leaf.error());
        if (!bytes) {
            events_.add("force_dropped", "",
                        "force of '" + e.leaf.path + "' (by " + e.by +
                            ") dropped by the new layout: " + bytes.error().message);
            continue;
        }
        auto old_before = variables::encodeValue(*leaf, before);
        e.leaf = *leaf;
        e.value = *bytes;
        e.before = old_before ? *old_before : *bytes;
        kept.push_back(std::move(e));
    }
    entries_ = std::move(kept);
    publish(false);
    dispatch::applyForces(board_.current());
}

}  // namespace irp::daemon
