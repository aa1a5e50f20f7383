// module_code.hpp -- where each loaded thread module's code lies in irpd's address space, for the
// crash handler (supervise/crash_record.hpp): which module a faulting instruction belongs to, and
// its offset from the module's load base, which the next start maps to a source line
// (supervise/source_line.hpp).  The main thread registers a module after its dlopen() and
// unregisters it before its dlclose(); the handler only compares numbers in a fixed table (dladdr
// is not async-signal-safe).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace irp::supervise {

// Where an instruction lies: the module whose code holds it, the file loaded, the offset from
// its load base (the address `addr2line -e image` takes).  Fixed buffers: filled in a signal handler.
struct CodeLocation {
    char module[64] = {};
    char image[512] = {};
    uintptr_t offset = 0;
};

// Main thread, after dlopen(): records the mapped segments of the library `handle` (its link map)
// as `module`'s code, loaded from `image`.  Returns its entry (for unregisterModuleCode), -1 when
// the table is full or the library cannot be found (the crash record then names no source).
int registerModuleCode(void *handle, const std::string &module, const std::string &image);
// Main thread, before dlclose(): forgets the entry (-1: nothing).
void unregisterModuleCode(int entry) noexcept;
// Async-signal-safe: the module whose code holds `pc`; false if none.
bool findModuleCode(uintptr_t pc, CodeLocation &out) noexcept;

}  // namespace irp::supervise
