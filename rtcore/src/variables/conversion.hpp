// conversion.hpp -- retyped shared variables whose values an online change keeps: the copies glbc
// --previous planned (layout.json "changes.converted", glb/glbc_compiler/convert.py holds the
// rules), checked against the running and the new layout, and run at the swap by the last executor
// to switch while irpd's main thread holds the new variables' locks (docs/hot-reload.md
// "Converted variables").
#pragma once

#include <indurop/result.hpp>
#include "variables/layout.hpp"

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace irp::variables {

// One scalar kind and size: 's' signed, 'u' unsigned, 'f' float, 'b' bool; 1, 2, 4 or 8 bytes.
struct ScalarCode {
    char kind = 0;
    uint8_t size = 0;
};

// `count` scalars from `from` (+ i * from_stride) to `to` (+ i * to_stride), offsets in the data area.
struct ScalarCopy {
    uint64_t from = 0, to = 0, count = 1, from_stride = 0, to_stride = 0;
    ScalarCode from_type, to_type;
};

struct Conversion {
    std::string path, from_type, to_type;  // the types as glbc spells them (`int16_t`, `a.s_t[4]`)
    std::vector<std::string> dropped;      // fields and elements the new type no longer has
    uint32_t to_lock = 0;                  // the new variable's lock, held from before the swap to the copy
    std::vector<ScalarCopy> copies;
};

// A retyped variable whose value cannot be kept: why (glbc's reason) and its types before and after
// as glbc names them (the IEC type of a variable declared by stc, else the C++ one).
struct NotConverted {
    std::string reason, from_type, to_type;
};

struct Conversions {
    std::vector<Conversion> converted;
    std::map<std::string, NotConverted> not_converted;  // a moved variable's path -> why its value is not kept
};

// The conversions `next` plans for the variables `diff` finds moved (same path, another type), when
// they were planned against the running layout (changes.previous is its hash; else none: every
// moved variable makes the set a restart case).  Every copy must lie inside its variable in both layouts; an
// Error naming the variable and the fix otherwise.
Result<Conversions> conversionsOf(const Layout &next, const layouts::Model &running,
                                  const std::vector<layouts::Moved> &moved);

// Runs the copies on the data area `data` (no allocation, no lock, no system call).
void convert(const Conversion &c, char *data) noexcept;

// At a swap (docs/hot-reload.md "Converted variables"):
//   hold      irpd's main thread, before the offer: takes each new variable's lock and makes its
//             sequence odd, so that nobody else writes it and readers wait for its value;
//   converted the RT thread of the last executor to take its new table, once no module of the old
//             set runs: converts into the held places and makes their sequences even (readers go on);
//   release   the main thread, after the swap: lets the locks go (and, when the swap never happened,
//             makes the sequences even again without converting).
void hold(const std::vector<Conversion> &all) noexcept;
void converted(const std::vector<Conversion> &all, char *data) noexcept;
void release(const std::vector<Conversion> &all, bool swapped) noexcept;

}  // namespace irp::variables
