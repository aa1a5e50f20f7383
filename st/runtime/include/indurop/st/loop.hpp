// loop.hpp -- the loop guard: the generated code calls loopCheck(place) on every back-edge of a
// FOR, WHILE and REPEAT loop (place: the loop's keyword).  When irpd asks the run in progress to
// end (its overrun watchdog found it past its <overrun_limit>, with <on_overrun> disable or stop:
// docs/faults.md), a back-edge soon after (every 64th polls) throws a RuntimeFault naming the loop's line, so an endless
// loop stops there and is named, and the rest of the set runs on.  One inline call site.
#pragma once

#include <indurop/indurop.h>
#include <indurop/st/fault.hpp>
#include <indurop/st/types.hpp>

#include <type_traits>

namespace irp {
// libindurop's flag (<indurop/indurop.h>): true while the calling thread module's run must end.
// Declared weak here, so that a module built with these headers still loads on a libindurop
// without it (an older SDK); the guard then never fires and <on_overrun> alone applies.
[[gnu::weak]] bool runAbortRequested() noexcept;
}  // namespace irp

namespace irp::st {

// Whether this process's libindurop has the flag at all.
inline bool runAbortAvailable() noexcept { return &::irp::runAbortRequested != nullptr; }

// Whether irpd asked the calling module's run to end.
inline bool runAbortRequested() noexcept { return runAbortAvailable() && ::irp::runAbortRequested(); }

// The check with the flag read by the caller (loopCheck(place) below is the one the code calls).
inline void loopCheck(const Place &place, bool abort) {
    if (abort) [[unlikely]]
        faultf(place, "the run passed its overrun limit in the loop at line %d: endless loop?", place.line);
}

namespace {
// Back-edges since the module was loaded (one counter per generated module: this header's unnamed
// namespace is its translation unit's own; a module runs on one thread at a time).
unsigned loopEdges = 0;
}  // namespace

// The flag is read on every 64th back-edge: a loop that runs on is still stopped within 64 turns of
// the request, and a short loop of a normal run seldom pays for the call into libindurop.
inline constexpr unsigned kLoopPollEvery = 64;

inline void loopCheck(const Place &place) {
    if (++loopEdges % kLoopPollEvery == 0) loopCheck(place, runAbortRequested());
}

// FOR i := a TO end BY step: the back-edge.  Advances i by step and says whether the loop goes on:
// while i has not passed end (i <= end for a positive step, i >= end for a negative one, the
// standard's termination rule).  Computed wide, so that a loop up to the type's maximum ends
// (FOR i := 32760 TO 32767 on an INT); i is then end + step wrapped, as the addition wraps.
template <Integer T, Integer S>
constexpr bool forStep(T &i, std::type_identity_t<T> end, S step) noexcept {
    const __int128 next = static_cast<__int128>(i) + static_cast<__int128>(step);
    i = static_cast<T>(static_cast<detail::WrapType<T>>(static_cast<unsigned __int128>(next)));
    return step > 0 ? next <= end : next >= end;
}

// Whether a FOR loop runs its body at all: the start value has not passed the end.
template <Integer T, Integer S>
constexpr bool forStarts(T i, std::type_identity_t<T> end, S step) noexcept {
    return step > 0 ? i <= end : i >= end;
}

}  // namespace irp::st
