// variables.hpp -- the I/O dispatcher's view of the shared variables: a path from ioconfig.xml
// resolved once (start()) to a scalar leaf of the running layout, with its C type, then read and
// written as a double through channel::Handle (RT-safe once the path was used: see
// <indurop/process.h>).
#pragma once

#include <indurop/process.h>

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

namespace irp::iodispat {

enum class ScalarKind { Signed, Unsigned, Float, Bool };

struct VarRef {
    std::string path;  // the full layout path ("PLC_ROBOT.AXIS_IN[2].position")
    ScalarKind kind = ScalarKind::Float;
    int size = 0;  // bytes: 1, 2, 4 or 8
    bool valid() const { return size != 0; }
};

// The scalar leaves of the layout in this process's shared-variable segment.
class VarTable {
public:
    // Reads the attached segment's layout; throws std::runtime_error when there is none.
    VarTable();

    // Resolves a path written in ioconfig.xml: the layout path, the same with "::" between the
    // namespace and the name (PLC_ROBOT::AXIS_IN[2].position), or without the namespace when
    // exactly one namespace has it.  Checks it is a scalar, then reads it once through the
    // handle (so that later accesses do not allocate).  Throws std::runtime_error("where: why").
    VarRef resolve(channel::Handle &handle, const std::string &path, const std::string &where) const;

    // A path that exists as a leaf (exact layout path), for optional members.
    bool hasLeaf(const std::string &path) const { return leaves_.count(path) != 0; }

private:
    struct Leaf {
        ScalarKind kind;
        int size;
    };
    std::unordered_map<std::string, Leaf> leaves_;
    std::vector<std::string> namespaces_;
};

// The variable's value as a double.  False (and out untouched) when the handle refuses.
bool readVar(channel::Handle &handle, const VarRef &v, double &out) noexcept;
// Stores value, rounded and clamped to the variable's type (bool: != 0).  False when refused.
bool writeVar(channel::Handle &handle, const VarRef &v, double value) noexcept;

}  // namespace irp::iodispat
