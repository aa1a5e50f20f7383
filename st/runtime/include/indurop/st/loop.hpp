// loop.hpp -- the loop guard: the generated code calls loopCheck(place) on every back-edge of a
// FOR, WHILE and REPEAT loop (place: the loop's keyword).  When irpd asks the run in progress to
// end (its overrun watchdog saw it pass its <overrun_limit>: docs/faults.md), the next back-edge
// throws a RuntimeFault naming the loop's line, so an endless loop stops there and is named, and
// the rest of the set runs on.  The poll is one inline call: a relaxed load on the fast path.
#pragma once

#include <indurop/indurop.h>
#include <indurop/st/fault.hpp>

namespace irp::st {

// Whether irpd asked the calling module's run to end.  The flag is libindurop's
// irp::runAbortRequested(), declared by <indurop/indurop.h> together with INDUROP_HAS_RUN_ABORT;
// an SDK without it never asks (the watchdog's <on_overrun> action still applies), so loops run on.
inline bool runAbortRequested() noexcept {
#ifdef INDUROP_HAS_RUN_ABORT
    return ::irp::runAbortRequested();
#else
    return false;
#endif
}

// The check with the flag read by the caller (loopCheck(place) below is the one the code calls).
inline void loopCheck(const Place &place, bool abort) {
    if (abort) [[unlikely]]
        faultf(place, "the run passed its overrun limit in the loop at line %d: endless loop?", place.line);
}

inline void loopCheck(const Place &place) { loopCheck(place, runAbortRequested()); }

}  // namespace irp::st
