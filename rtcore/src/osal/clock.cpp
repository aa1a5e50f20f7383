// clock.cpp -- CLOCK_MONOTONIC absolute sleeps (never a relative sleep: no drift).
#include "osal/clock.hpp"

#include <cerrno>

namespace irp::osal {

void MonotonicClock::sleepUntil(int64_t deadline) noexcept {
    timespec ts{static_cast<time_t>(deadline / 1'000'000'000), static_cast<long>(deadline % 1'000'000'000)};
    // EINTR (a signal) restarts the same absolute wait; nothing else can fail with valid arguments.
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {}
}

MonotonicClock &monotonicClock() noexcept {
    static MonotonicClock clock;
    return clock;
}

}  // namespace irp::osal
