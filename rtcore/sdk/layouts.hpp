// layouts.hpp -- what a layout.json says about its top-level variables and its lineage, and the
// two questions online change asks of it (docs/shared-variables.md, "Layouts that evolve"):
//
//   compatible  may code built against layout H (the hash stamped into a module) run on this
//               layout?  Yes when H is this layout, or a layout of its lineage (glbc --previous)
//               whose every variable is here with the same type, offset and lock, or is gone
//               and left a hole that nothing else uses (its lock: nothing outside its lock group).
//   diff        what changes from the running layout to the next, and whether the segment can
//               take it online: every variable kept (same path and type) stays where it is, and
//               everything new lies in room that neither layout nor the lineage uses.
//
// Shared by irpd (thread modules, the reloader) and libindurop (process modules at start), so
// that both accept exactly the same modules.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace irp::layouts {

struct Variable {
    std::string path, type_id;
    uint64_t offset = 0, size = 0;
    uint32_t lock = 0;
    bool internal = false;   // a compiler's own ("internal": true, stc's init flags): kept, never reported
    std::string lock_group;  // "lock_group": the variables of one group share their lock by design
};

// Whether a and b use one lock other than as a lock group's members (glbc gives a group one lock).
bool sameLock(const Variable &a, const Variable &b);

struct Table {
    std::string hash;
    std::vector<Variable> variables;
    const Variable *find(std::string_view path) const;
};

struct Model {
    Table self;
    std::vector<Table> lineage;  // the layouts this one was laid out against, newest first
    uint64_t data_size = 0;
    uint32_t lock_count = 0;
};

// Parses a layout.json text (or takes an already parsed one); nullopt with `error` set when it is
// not one.
std::optional<Model> parse(std::string_view text, std::string &error);
std::optional<Model> fromJson(const nlohmann::json &doc, std::string &error);

// "" when code built against layout `built` may run on `model`, else why not (naming the variable).
std::string compatible(std::string_view built, const Model &model);

struct Moved {
    std::string path;
    uint64_t from = 0, to = 0;
};

struct Diff {
    std::vector<std::string> added, removed;
    std::vector<std::string> internal;  // those of added and removed that are a compiler's own
    std::vector<Moved> moved;           // same path, another type: a new place
    // Empty when the next layout can be published over the running one; else why not.
    std::string online_impossible;
};

Diff diff(const Model &running, const Model &next);

}  // namespace irp::layouts
