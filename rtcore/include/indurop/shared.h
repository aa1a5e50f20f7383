// shared.h -- shared variables: typed references into the segment that glbc lays out and irpd
// creates, used like ordinary globals (`tick = tick + 10; joints[0] = v; v.x`).
//
// <indurop/generated.h> (written by glbc from .glb files) declares every variable as a constexpr
// reference object of the types below; none of them holds data, each names an offset in the
// segment and the lock of its top-level variable.  The segment is mapped once per process
// (by irpd before it loads thread modules; by libindurop at start-up in a process module) and
// every access resolves against that mapping.
//
// Consistency (docs/shared-variables.md has the whole design):
//   - a scalar read or a top-level scalar write is one atomic load or store: never torn;
//   - a struct or array read is a seqlock read of its top-level variable: it retries while a
//     writer is inside, and after kSpinReads retries takes the variable's lock, a
//     priority-inheritance mutex, so that a preempted writer is boosted instead of starved;
//   - every other write (a struct, an array, a member or element, any compound assignment
//     such as `tick += 10`) takes the variable's PI mutex, shared between processes and robust
//     (a writer that dies inside is detected and the sequence repaired).
// Readers never take a lock on the fast path, so a non-RT reader never blocks an RT writer.
// `tick = tick + 10` is a read and then a write, as with any global; `tick += 10` is atomic.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <pthread.h>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

extern "C" {

// The lock of one top-level variable, in the segment's lock table.
struct alignas(64) indurop_var_lock {
    pthread_mutex_t mutex;  // PTHREAD_PRIO_INHERIT, PTHREAD_PROCESS_SHARED, PTHREAD_MUTEX_ROBUST
    uint32_t seq;           // even: stable; odd: a writer is inside (accessed atomically)
};

// Where this process mapped the segment (null until then).  Set by libindurop.
extern char *indurop_shared_data;
extern indurop_var_lock *indurop_shared_locks;

}  // extern "C"

// One lock per cache line.  Readers in other languages find `seq` in irpd's description of the
// segment (`irpd --print-shm-layout`, docs/shared-memory.md).
static_assert(sizeof(indurop_var_lock) == 64, "a lock-table entry is one cache line");

namespace irp::shared {

using VarLock = indurop_var_lock;

// Seqlock retries before a reader falls back to the lock.
inline constexpr int kSpinReads = 64;

// Lock and unlock a top-level variable (robust PI mutex; repairs the sequence of a writer that died).
void lockVariable(uint32_t lock) noexcept;
void unlockVariable(uint32_t lock) noexcept;

// ---- the segment in this process ----------------------------------------------------------
// Maps the segment `name` ("/indurop.default.vars") and makes the generated variables refer to
// it; "" on success, else why not.  A process module started by irpd is attached before main()
// (irpd passes the name in INDUROP_SHM); attachError() then says whether that worked.
std::string attach(const std::string &name, bool writable = true);
void detach() noexcept;
// The attached segment's layout as published last, copied consistently (an online change may
// publish another at any time, docs/shared-variables.md): its hash and its layout.json text;
// both empty when no segment is attached.  They allocate: not for run().
std::string layoutHash();
std::string layoutText();
// Both from one publication.
void layoutCopy(std::string &hash, std::string &text);
const std::string &attachError() noexcept;
// Locks taken over from a writer that died while holding them, since this process started.
uint64_t repairedLocks() noexcept;

namespace detail {

inline std::atomic_ref<uint32_t> sequence(uint32_t lock) noexcept {
    return std::atomic_ref<uint32_t>(indurop_shared_locks[lock].seq);
}

// Copies n bytes with relaxed atomic accesses in the widest chunks both ends allow, so that
// a racing writer is a detected retry, not undefined behaviour.
inline void atomicCopy(void *dst, const void *src, std::size_t n) noexcept {
    auto d = reinterpret_cast<uintptr_t>(dst), s = reinterpret_cast<uintptr_t>(src);
    auto copy = [&](auto word) {
        using W = decltype(word);
        for (std::size_t i = 0; i < n; i += sizeof(W))
            __atomic_store_n(reinterpret_cast<W *>(d + i),
                             __atomic_load_n(reinterpret_cast<const W *>(s + i), __ATOMIC_RELAXED), __ATOMIC_RELAXED);
    };
    const uintptr_t misalign = d | s | n;
    if ((misalign & 7) == 0)
        copy(uint64_t{});
    else if ((misalign & 3) == 0)
        copy(uint32_t{});
    else if ((misalign & 1) == 0)
        copy(uint16_t{});
    else
        copy(uint8_t{});
}

// Runs copy() until it saw no writer (seqlock), or under the lock after kSpinReads tries.
template <class Copy>
inline void readConsistent(uint32_t lock, Copy copy) noexcept {
    auto seq = sequence(lock);
    for (int attempt = 0; attempt < kSpinReads; ++attempt) {
        uint32_t before = seq.load(std::memory_order_acquire);
        if (before & 1) {
            __builtin_ia32_pause();
            continue;
        }
        copy();
        std::atomic_thread_fence(std::memory_order_acquire);
        if (seq.load(std::memory_order_relaxed) == before) return;
    }
    lockVariable(lock);
    copy();
    unlockVariable(lock);
}

// The writer's side of the seqlock: the variable's lock taken and its sequence made odd; returns the
// sequence before, which endWrite() makes even again (+2) before it gives the lock back.
inline uint32_t beginWrite(uint32_t lock) noexcept {
    lockVariable(lock);
    auto seq = sequence(lock);
    uint32_t s = seq.load(std::memory_order_relaxed);
    seq.store(s + 1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    return s;
}

inline void endWrite(uint32_t lock, uint32_t before) noexcept {
    sequence(lock).store(before + 2, std::memory_order_release);
    unlockVariable(lock);
}

// Runs write() under the variable's lock, with the sequence odd meanwhile.
template <class Write>
inline void writeExclusive(uint32_t lock, Write write) noexcept {
    const uint32_t before = beginWrite(lock);
    write();
    endWrite(lock, before);
}

}  // namespace detail

// Every reference: an offset into the data area and the lock index of its top-level variable.
class RefBase {
public:
    constexpr RefBase(uint64_t offset, uint32_t lock) : offset_(offset), lock_(lock) {}
    constexpr RefBase(const RefBase &) = default;
    RefBase &operator=(const RefBase &) = delete;  // assigning a reference writes data (see the derived classes)
    constexpr uint64_t offset() const { return offset_; }
    constexpr uint32_t lockIndex() const { return lock_; }
    char *address() const { return indurop_shared_data + offset_; }

protected:
    uint64_t offset_;
    uint32_t lock_;
};

// A scalar: integer, floating point, bool or enum.
template <class T>
class ScalarRef : public RefBase {
    static_assert(std::is_arithmetic_v<T> || std::is_enum_v<T>, "ScalarRef holds arithmetic types");

public:
    using value_type = T;

    // in_aggregate: a member or element of a struct or array (writes then keep its seqlock).
    constexpr ScalarRef(uint64_t offset, uint32_t lock, bool in_aggregate = false)
        : RefBase(offset, lock), in_aggregate_(in_aggregate) {}
    constexpr ScalarRef(const ScalarRef &) = default;

    T load() const noexcept { return std::atomic_ref<T>(*ptr()).load(std::memory_order_acquire); }
    operator T() const noexcept { return load(); }

    void store(T v) const noexcept {
        if (!in_aggregate_)
            std::atomic_ref<T>(*ptr()).store(v, std::memory_order_release);
        else
            detail::writeExclusive(lock_, [&] { std::atomic_ref<T>(*ptr()).store(v, std::memory_order_relaxed); });
    }
    T operator=(T v) const noexcept {
        store(v);
        return v;
    }
    T operator=(const ScalarRef &other) const noexcept { return *this = other.load(); }

    // Read-modify-write under the variable's lock: atomic with respect to every other writer.
    template <class Fn>
    T update(Fn fn) const noexcept {
        T result;
        detail::writeExclusive(lock_, [&] {
            std::atomic_ref<T> cell(*ptr());
            result = static_cast<T>(fn(cell.load(std::memory_order_relaxed)));
            cell.store(result, std::memory_order_relaxed);
        });
        return result;
    }
    T operator+=(T d) const noexcept {
        return update([d](T v) { return v + d; });
    }
    T operator-=(T d) const noexcept {
        return update([d](T v) { return v - d; });
    }
    T operator*=(T d) const noexcept {
        return update([d](T v) { return v * d; });
    }
    T operator/=(T d) const noexcept {
        return update([d](T v) { return v / d; });
    }
    T operator++() const noexcept {
        return update([](T v) { return v + 1; });
    }
    T operator--() const noexcept {
        return update([](T v) { return v - 1; });
    }
    T operator++(int) const noexcept {
        return static_cast<T>(update([](T v) { return v + 1; }) - 1);
    }
    T operator--(int) const noexcept {
        return static_cast<T>(update([](T v) { return v - 1; }) + 1);
    }
    template <class U = T, class = std::enable_if_t<std::is_integral_v<U>>>
    T operator|=(T d) const noexcept {
        return update([d](T v) { return v | d; });
    }
    template <class U = T, class = std::enable_if_t<std::is_integral_v<U>>>
    T operator&=(T d) const noexcept {
        return update([d](T v) { return v & d; });
    }
    template <class U = T, class = std::enable_if_t<std::is_integral_v<U>>>
    T operator^=(T d) const noexcept {
        return update([d](T v) { return v ^ d; });
    }

private:
    T *ptr() const noexcept { return reinterpret_cast<T *>(indurop_shared_data + offset_); }
    bool in_aggregate_;
};

// A struct: read and written whole, consistently; glbc derives one class per struct type that
// adds a reference member per field (so `ROBOT_MODULE_STATE.eState` reads one field).
template <class V>
class StructRef : public RefBase {
    static_assert(std::is_trivially_copyable_v<V>, "shared structs are plain data");

public:
    using value_type = V;
    constexpr StructRef(uint64_t offset, uint32_t lock) : RefBase(offset, lock) {}
    constexpr StructRef(const StructRef &) = default;

    V load() const noexcept {
        V v;
        detail::readConsistent(lock_, [&] { detail::atomicCopy(&v, address(), sizeof(V)); });
        return v;
    }
    operator V() const noexcept { return load(); }

    V operator=(const V &v) const noexcept {
        detail::writeExclusive(lock_, [&] { detail::atomicCopy(address(), &v, sizeof(V)); });
        return v;
    }
    // Copies another shared struct's value (read consistently, then written under this lock).
    V operator=(const StructRef &other) const noexcept { return *this = other.load(); }

    // Read-modify-write of the whole struct under the variable's lock.
    template <class Fn>
    void update(Fn fn) const noexcept {
        detail::writeExclusive(lock_, [&] {
            V v;
            detail::atomicCopy(&v, address(), sizeof(V));
            fn(v);
            detail::atomicCopy(address(), &v, sizeof(V));
        });
    }
};

// An array of N elements of ElemRef (a ScalarRef, a struct reference, or an ArrayRef for the
// next dimension).  Indexing is unchecked, as for a C array; at() checks.
template <class ElemRef, std::size_t N>
class ArrayRef : public RefBase {
public:
    using reference = ElemRef;
    // What one element reads as: a scalar, a struct, or a whole row (std::array) for the inner
    // dimension of a multi-dimensional array.
    using value_type = decltype(std::declval<const ElemRef &>().load());
    using array_type = std::array<value_type, N>;
    static constexpr std::size_t extent = N;

    constexpr ArrayRef(uint64_t offset, uint32_t lock, bool /*in_aggregate*/ = false) : RefBase(offset, lock) {}
    constexpr ArrayRef(const ArrayRef &) = default;

    static constexpr std::size_t size() { return N; }
    constexpr ElemRef operator[](std::size_t i) const noexcept {
        return ElemRef(offset_ + i * sizeof(value_type), lock_, true);
    }
    // Checked indexing; throws std::out_of_range, so not for run() on the RT thread.
    ElemRef at(std::size_t i) const {
        if (i >= N) throw std::out_of_range("shared array index out of range");
        return (*this)[i];
    }

    array_type load() const noexcept {
        array_type a;
        detail::readConsistent(lock_, [&] { detail::atomicCopy(a.data(), address(), sizeof(a)); });
        return a;
    }
    operator array_type() const noexcept { return load(); }
    array_type operator=(const array_type &a) const noexcept {
        detail::writeExclusive(lock_, [&] { detail::atomicCopy(address(), a.data(), sizeof(a)); });
        return a;
    }
    // Copies another shared array's value (read consistently, then written under this lock).
    array_type operator=(const ArrayRef &other) const noexcept { return *this = other.load(); }
};

}  // namespace irp::shared

// The type of a shared variable's reference; `INDUROP_TYPEDEF(joints)::value_type` is the type
// of one element (Figure 5), `INDUROP_TYPEDEF(tick)::value_type` the scalar type.
#define INDUROP_TYPEDEF(variable) std::remove_cv_t<std::remove_reference_t<decltype(variable)>>
