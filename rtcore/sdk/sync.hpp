// sync.hpp -- the monotonic clock and the process-shared futex calls, written once for both sides
// of the control segment: libindurop (a process module's period handshake and calls) and irpd (the
// dispatcher releasing processes, the call server answering, the supervisor).  Not installed.
//
// The futex words live in shared memory, so no FUTEX_PRIVATE_FLAG: irpd and the processes wait
// and wake on the same words.  Everything here is safe on an RT thread: one syscall, no allocation.
#pragma once

#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <bit>
#include <cerrno>
#include <climits>
#include <cstdint>
#include <ctime>

namespace irp {

// CLOCK_MONOTONIC in nanoseconds (the vDSO: no syscall).
inline int64_t monotonicNs() noexcept {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

namespace futex {

// Wakes every waiter on `word`.
inline void wakeAll(uint32_t *word) noexcept { syscall(SYS_futex, word, FUTEX_WAKE, INT32_MAX, nullptr, nullptr, 0); }

// One FUTEX_WAIT while *word == expected, at most timeout_ns (<= 0: no limit).  Returns on a wake,
// a signal, a changed word or the timeout alike (EAGAIN, EINTR, ETIMEDOUT): the caller re-checks.
inline void wait(uint32_t *word, uint32_t expected, int64_t timeout_ns = 0) noexcept {
    timespec rel{static_cast<time_t>(timeout_ns / 1'000'000'000), static_cast<long>(timeout_ns % 1'000'000'000)};
    syscall(SYS_futex, word, FUTEX_WAIT, expected, timeout_ns > 0 ? &rel : nullptr, nullptr, 0);
}

// One FUTEX_WAIT_BITSET while *word == expected, at most until the absolute CLOCK_MONOTONIC time
// `until` (one hrtimer on that time, no clock read).  Returns as wait() does: the caller re-checks.
inline void waitUntil(uint32_t *word, uint32_t expected, int64_t until) noexcept {
    const timespec at{static_cast<time_t>(until / 1'000'000'000), static_cast<long>(until % 1'000'000'000)};
    syscall(SYS_futex, word, FUTEX_WAIT_BITSET, expected, &at, nullptr, FUTEX_BITSET_MATCH_ANY);
}

// The futex word of a 64-bit field: its low 32 bits (little-endian: the field's first four bytes),
// which any change of a nanosecond time or a marker almost always changes.  Used to wait on a
// release made ahead's release_at_ns (control.h), so that irpd's compare-and-swap of it is seen
// by the futex's compare even when irpd's wake comes before the wait.
inline uint32_t *lowWord(int64_t *field) noexcept {
    static_assert(std::endian::native == std::endian::little, "the low word of a 64-bit field is its first four bytes");
    return reinterpret_cast<uint32_t *>(field);
}

// Waits until *word != expected (acquire), at most timeout_ns (<= 0: no limit).  False on timeout.
inline bool waitWhileEqual(uint32_t *word, uint32_t expected, int64_t timeout_ns) noexcept {
    const int64_t deadline = timeout_ns > 0 ? monotonicNs() + timeout_ns : 0;
    std::atomic_ref<uint32_t> value(*word);
    while (value.load(std::memory_order_acquire) == expected) {
        int64_t left = 0;
        if (deadline && (left = deadline - monotonicNs()) <= 0) return false;
        wait(word, expected, left);
    }
    return true;
}

}  // namespace futex
}  // namespace irp
