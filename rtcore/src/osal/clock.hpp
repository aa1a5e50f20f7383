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
};

inline int64_t monotonicNow() noexcept { return irp::monotonicNs(); }  // sdk/sync.hpp

class MonotonicClock final : public Clock {
public:
    int64_t now() noexcept override { return monotonicNow(); }
    void sleepUntil(int64_t deadline) noexcept override;
};

// The process-wide real clock.
MonotonicClock &monotonicClock() noexcept;

}  // namespace irp::osal
