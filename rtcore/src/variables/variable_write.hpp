// variable_write.hpp -- one shared variable's leaf by its path, for irpd's control thread: found in
// the running layout, a JSON value checked against its type and encoded as its bytes (and back),
// and written under the variable's lock through libindurop's path access, as a process would
// (the agent's PUT /variables/{path}; forcing, docs/forcing.md).
#pragma once

#include <indurop/result.hpp>

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <string>

namespace irp::variables {

// A scalar of the layout: a top-level one, a struct member or an array element.
struct Leaf {
    std::string path;
    std::string type;  // the layout's type name (uint64_t, double, bool, ...)
    std::string kind;  // its scalar kind: float, bool, signed, unsigned, char
    uint64_t offset = 0;
    uint32_t size = 0;  // 1, 2, 4 or 8
    uint32_t lock = 0;
};

// A leaf's value as its bytes (the first `size` used).
using LeafBytes = std::array<unsigned char, 8>;

// The leaf `path` of `layout` (the running layout.json, parsed), or an Error naming what to fix:
// an unknown path (with a hint), or a struct or an array as a whole (its members are named).
Result<Leaf> findLeaf(const nlohmann::json &layout, const std::string &path);
// value checked against the leaf's type and range, as its bytes.
Result<LeafBytes> encodeValue(const Leaf &leaf, const nlohmann::json &value);
// The bytes of a leaf as JSON (a number or a boolean).
nlohmann::ordered_json decodeValue(const Leaf &leaf, const LeafBytes &bytes);
// The leaf's current bytes, read consistently (seqlock) from this process's segment.
LeafBytes readLeaf(const Leaf &leaf) noexcept;
// Writes bytes to the leaf under its variable's lock (libindurop's path access).
Status writeLeaf(const Leaf &leaf, const LeafBytes &bytes);

// Returns {"path", "value"} (the value as stored), or an Error naming what to fix: unknown path
// (with a hint), a value of the wrong type, out of range.
Result<nlohmann::ordered_json> writeByPath(const nlohmann::json &layout, const std::string &path,
                                           const nlohmann::json &value);

}  // namespace irp::variables
