// layouts.cpp -- layout.json's variables and lineage, compatibility and the online diff.
#include "layouts.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <map>
#include <set>

namespace irp::layouts {
namespace {

std::string shortHash(std::string_view h) { return std::string(h.substr(0, 12)) + "…"; }

Table tableOf(const nlohmann::json &hash, const nlohmann::json &variables) {
    Table t;
    t.hash = hash.get<std::string>();
    for (const auto &v : variables)
        t.variables.push_back(Variable{v.at("path").get<std::string>(), v.value("type_id", std::string{}),
                                       v.at("offset").get<uint64_t>(), v.at("size").get<uint64_t>(),
                                       v.at("lock").get<uint32_t>(), v.value("internal", false),
                                       v.value("lock_group", std::string{})});
    return t;
}

// A type_id of "" (a layout written before type ids) is equal to nothing.
bool sameType(const Variable &a, const Variable &b) { return !a.type_id.empty() && a.type_id == b.type_id; }

bool overlaps(const Variable &a, const Variable &b) {
    return a.offset < b.offset + b.size && b.offset < a.offset + a.size;
}

std::string place(const Variable &v) {
    return "offset " + std::to_string(v.offset) + ", lock " + std::to_string(v.lock);
}

}  // namespace

bool sameLock(const Variable &a, const Variable &b) {
    return a.lock == b.lock && (a.lock_group.empty() || a.lock_group != b.lock_group);
}

const Variable *Table::find(std::string_view path) const {
    for (const Variable &v : variables)
        if (v.path == path) return &v;
    return nullptr;
}

std::optional<Model> parse(std::string_view text, std::string &error) {
    try {
        return fromJson(nlohmann::json::parse(text), error);
    } catch (const nlohmann::json::exception &e) {
        error = std::string("malformed layout: ") + e.what();
        return std::nullopt;
    }
}

std::optional<Model> fromJson(const nlohmann::json &doc, std::string &error) {
    try {
        Model m;
        m.self = tableOf(doc.at("hash"), doc.at("variables"));
        m.data_size = doc.at("data_size").get<uint64_t>();
        m.lock_count = doc.at("lock_count").get<uint32_t>();
        if (auto it = doc.find("lineage"); it != doc.end() && it->is_array())
            for (const auto &entry : *it) m.lineage.push_back(tableOf(entry.at("hash"), entry.at("variables")));
        return m;
    } catch (const nlohmann::json::exception &e) {
        error = std::string("malformed layout: ") + e.what();
        return std::nullopt;
    }
}

std::string compatible(std::string_view built, const Model &model) {
    if (built == model.self.hash) return "";
    const Table *was = nullptr;
    for (const Table &t : model.lineage)
        if (t.hash == built) was = &t;
    if (!was)
        return "it was built against shared-variable layout " + std::string(built) + ", which is neither the layout " +
               model.self.hash +
               " nor one that layout was laid out against (glbc --previous): rebuild it against "
               "the set's .glb files";
    for (const Variable &v : was->variables) {
        if (const Variable *now = model.self.find(v.path)) {
            if (!sameType(v, *now) || now->offset != v.offset || now->lock != v.lock)
                return "it was built against layout " + shortHash(built) + ", in which '" + v.path + "' is at " +
                       place(v) + (sameType(v, *now) ? "" : " with another type") + "; layout " +
                       shortHash(model.self.hash) + " has it at " + place(*now) +
                       ": rebuild it against the set's .glb files";
            continue;
        }
        // Gone: its bytes and lock must be a hole nothing else uses.
        for (const Variable &other : model.self.variables)
            if (overlaps(v, other) || sameLock(other, v))
                return "it was built against layout " + shortHash(built) + ", in which '" + v.path + "' (" + place(v) +
                       ") lies where '" + other.path + "' is now: rebuild it against the set's .glb files";
    }
    return "";
}

Diff diff(const Model &running, const Model &next) {
    Diff d;
    if (running.self.hash == next.self.hash) return d;
    // Bytes and locks that code of the running generation may still address: the running layout
    // and every layout of its lineage (modules built against them may be running).
    std::vector<const Variable *> in_use;
    for (const Variable &v : running.self.variables) in_use.push_back(&v);
    for (const Table &t : running.lineage)
        for (const Variable &v : t.variables) in_use.push_back(&v);

    // A variable that keeps its type must keep its place: the most telling reason, so it comes first.
    for (const Variable &v : next.self.variables) {
        const Variable *old = running.self.find(v.path);
        if (old && sameType(*old, v) && (old->offset != v.offset || old->lock != v.lock)) {
            d.online_impossible = "variable '" + v.path + "' keeps its type but moves from " + place(*old) + " to " +
                                  place(v) +
                                  ": the new layout was not laid out against the running one (glbc --previous)";
            break;
        }
    }
    for (const Variable &v : next.self.variables) {
        const Variable *old = running.self.find(v.path);
        if (old && sameType(*old, v)) continue;
        if (old)
            d.moved.push_back(Moved{v.path, old->offset, v.offset});
        else
            d.added.push_back(v.path);
        if (!old && v.internal) d.internal.push_back(v.path);
        if (!d.online_impossible.empty()) continue;
        for (const Variable *u : in_use) {
            const bool same_place = overlaps(*u, v) || sameLock(*u, v);
            if (!same_place) continue;
            if (u->path == v.path && old && old->offset == v.offset)
                d.online_impossible = "variable '" + v.path + "' changes its type in place (" + place(v) +
                                      "): running modules would read the new bytes as the old type";
            else
                d.online_impossible = "variable '" + v.path + "' (" + place(v) + ") lies where '" + u->path +
                                      "' of the running layout is (" + place(*u) +
                                      "): lay the .glb files out "
                                      "against the running layout (glbc --previous)";
            break;
        }
    }
    for (const Variable &v : running.self.variables) {
        if (next.self.find(v.path)) continue;
        d.removed.push_back(v.path);
        if (v.internal) d.internal.push_back(v.path);
    }
    return d;
}

}  // namespace irp::layouts
