// clock.hpp -- the time source of the dispatcher: now() and sleepUntil() on one clock.
//
// The dispatcher only ever sleeps until an absolute time; the real clock is CLOCK_MONOTONIC with
// clock_nanosleep(TIMER_ABSTIME), and tests substitute a clock that steps instantly.
#pragma once

#include "sdk/sync.hpp"

#include <cstdint>
#include <ctime>

namespace irp::osal {

class Clock {
public:
    virtual ~Clock() = default;
    virtual int64_t now() noexcept = 0;                      // nanoseconds
    virtual void sleepUntil(int64_t deadline) noexcept = 0;  // returns at or after deadline
    // Sleeps until *word is no longer `expected` (and a FUTEX_WAKE came) or until deadline; false
    // at the deadline.  A clock that is not the real one only sleeps until the deadline.
    virtual bool waitUntil(uint32_t *word, uint32_t expected, int64_t deadline) noexcept {
        (void)word;
        (void)expected;
        sleepUntil(deadline);
        return false;
    }
};

inline int64_t monotonicNow() noexcept { return irp::monotonicNs(); }  // sdk/sync.hpp

class MonotonicClock final : public Clock {
public:
    int64_t now() noexcept override { return monotonicNow(); }
    void sleepUntil(int64_t deadline) noexcept override;
    bool waitUntil(uint32_t *word, uint32_t expected, int64_t deadline) noexcept override {
        futex::waitUntil(word, expected, deadline);
        return monotonicNow() < deadline;
    }
};

// The process-wide real clock.
MonotonicClock &monotonicClock() noexcept;

}  // namespace irp::osal
