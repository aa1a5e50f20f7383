// in_place.hpp -- a PROGRAM instance whose variables the segment lays out as its C++ struct (glbc puts
// them in declaration order, each at its alignment, unless an online change added one elsewhere) is
// run in place: run() works on the segment's bytes themselves, without a local copy, a snapshot or a
// write-back.  The instance's struct and array variables are one lock group (emit_glb.py); for the
// length of the run the module is that group's writer: it holds the group's lock with the sequence
// odd, so that a reader of any of them retries (and after kSpinReads retries waits on the lock,
// boosting the run: a priority-inheritance mutex), and irpd's writes and forces of them wait for the
// run's end.  A reader sees every struct and array of the instance as one run left them, as with the
// kept image (kept.hpp).  The instance's scalars are read and written in place as well: one aligned
// load or store each, as irpd and the other modules access a scalar; a reader may see a scalar a run
// changes twice at its first value, as it would a C++ module's.
//
//   auto &self = inPlace<Main>(::main::first);
//   const uint32_t group_ = openGroup(lock);
//   try { programBody(self); } catch (...) { closeGroup(lock, group_); ...; throw; }  closeGroup(lock, group_);
//
// docs/st-runtime.md, "In place".
#pragma once

#include <indurop/shared.h>

#include <cstdint>

namespace irp::st {

// The instance's struct at its first variable's place in the segment.
template <class Program>
inline Program &inPlace(const shared::RefBase &first) noexcept {
    return *reinterpret_cast<Program *>(first.address());
}

// The run becomes the group's writer (shared.h's beginWrite: its lock taken, a robust PI mutex that a
// module dying inside leaves repaired; its sequence odd); returns what closeGroup() needs.
inline uint32_t openGroup(uint32_t lock) noexcept { return shared::detail::beginWrite(lock); }

// The run's writes are published: the sequence even again (a release store), the lock given back.
inline void closeGroup(uint32_t lock, uint32_t opened) noexcept { shared::detail::endWrite(lock, opened); }

}  // namespace irp::st
