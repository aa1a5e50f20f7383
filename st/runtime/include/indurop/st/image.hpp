// image.hpp -- the process image of a generated module (PLAN29.md, "Execution model"): at the
// start of run() copyIn() takes one consistent read of each shared variable the code touches into
// a local value and a snapshot; the code runs on the locals; at the end writeBack() writes back
// what differs from the snapshot, under the variable's write lock.  A value written from outside
// during the run therefore survives unless the program changed the same bytes.  A fault throws
// past writeBack(): a faulting run writes nothing, the variables keep the last complete run's values.
//
//   static PLC_IN_t in, in0;                       // the local and its snapshot
//   irp::st::copyIn(PLC_ROBOT::PLC_IN, in, in0);
//   ... the program on `in` ...
//   irp::st::writeBack(PLC_ROBOT::PLC_IN, in, in0);
//
// Granularity: a scalar variable is one atomic load and, if changed, one atomic store (the
// segment's rule for top-level scalars).  A struct or an array is compared byte by byte; each
// aligned word of the value's alignment (at most 8 bytes, so no leaf straddles two) that holds a
// changed byte is rewritten as one atomic store that merges the changed bytes into the word read
// under the lock.  So a leaf the program did not change keeps what another writer put there
// during the run.  (A leaf that both the program and another writer changed in the same run gets
// the program's changed bytes over the other writer's value.)
//
// Also the cycle time: cycleTime() is the due time of the period in progress, the time base of
// TON, TOF and TP.  None of these allocates or makes a system call (an uncontended lock is a CAS).
#pragma once

#include <indurop/indurop.h>
#include <indurop/shared.h>
#include <indurop/st/types.hpp>

#include <cstdint>
#include <cstring>
#include <type_traits>

namespace irp::st {

// The due time of the period in progress: CLOCK_MONOTONIC nanoseconds of irp::cycle().planned_ns
// (0 outside run()).  Successive runs of a module see it advance by exactly their period.
inline TIME cycleTime() noexcept { return ::irp::cycle().planned_ns; }

// ---- scalars ------------------------------------------------------------------------------------

template <class T>
inline void copyIn(const shared::ScalarRef<T> &ref, T &local, T &snapshot) noexcept {
    local = snapshot = ref.load();
}

template <class T>
inline void writeBack(const shared::ScalarRef<T> &ref, const T &local, const T &snapshot) noexcept {
    if (std::memcmp(&local, &snapshot, sizeof(T)) != 0) ref.store(local);
}

namespace detail {

template <class W>
inline void mergeWords(char *shared, const char *local, const char *snapshot, std::size_t size) noexcept {
    for (std::size_t at = 0; at < size; at += sizeof(W)) {
        W l, s;
        std::memcpy(&l, local + at, sizeof(W));
        std::memcpy(&s, snapshot + at, sizeof(W));
        const W diff = static_cast<W>(l ^ s);
        if (diff == 0) continue;
        W mask = 0;
        for (std::size_t b = 0; b < sizeof(W); ++b)
            if ((diff >> (8 * b)) & 0xff) mask = static_cast<W>(mask | (W{0xff} << (8 * b)));
        W *cell = reinterpret_cast<W *>(shared + at);
        const W now = __atomic_load_n(cell, __ATOMIC_RELAXED);
        __atomic_store_n(cell, static_cast<W>((now & static_cast<W>(~mask)) | (l & mask)), __ATOMIC_RELAXED);
    }
}

// The changed words of `size` bytes at ref's place, under its lock; Align: the value's alignment.
template <std::size_t Align>
inline void writeChanged(const shared::RefBase &ref, const void *local, const void *snapshot,
                         std::size_t size) noexcept {
    if (std::memcmp(local, snapshot, size) == 0) return;
    const auto *l = static_cast<const char *>(local), *s = static_cast<const char *>(snapshot);
    shared::detail::writeExclusive(ref.lockIndex(), [&] {
        char *to = ref.address();
        if constexpr (Align >= 8)
            mergeWords<uint64_t>(to, l, s, size);
        else if constexpr (Align == 4)
            mergeWords<uint32_t>(to, l, s, size);
        else if constexpr (Align == 2)
            mergeWords<uint16_t>(to, l, s, size);
        else
            mergeWords<uint8_t>(to, l, s, size);
    });
}

template <class Value, class Local>
inline void readInto(const shared::RefBase &ref, Local &local, Local &snapshot) noexcept {
    static_assert(sizeof(Local) == sizeof(Value) && std::is_trivially_copyable_v<Local>,
                  "the local of a shared variable has its size and is plain data");
    shared::detail::readConsistent(ref.lockIndex(),
                                   [&] { shared::detail::atomicCopy(&local, ref.address(), sizeof(Local)); });
    std::memcpy(&snapshot, &local, sizeof(Local));
}

template <class Value, class Local>
inline void writeFrom(const shared::RefBase &ref, const Local &local, const Local &snapshot) noexcept {
    static_assert(sizeof(Local) == sizeof(Value) && std::is_trivially_copyable_v<Local>,
                  "the local of a shared variable has its size and is plain data");
    writeChanged<alignof(Value)>(ref, &local, &snapshot, sizeof(Local));
}

}  // namespace detail

// ---- structs (glbc's StructRef and the classes it derives from it) ------------------------------
// Local: the struct itself, or any plain type of its size (a String<N> for a char[N+1] field).

template <class V, class Local>
inline void copyIn(const shared::StructRef<V> &ref, Local &local, Local &snapshot) noexcept {
    detail::readInto<V>(ref, local, snapshot);
}

template <class V, class Local>
inline void writeBack(const shared::StructRef<V> &ref, const Local &local, const Local &snapshot) noexcept {
    detail::writeFrom<V>(ref, local, snapshot);
}

// ---- arrays (Local: std::array of the elements, nested for more dimensions, or a C array) -------

template <class E, std::size_t N, class Local>
inline void copyIn(const shared::ArrayRef<E, N> &ref, Local &local, Local &snapshot) noexcept {
    detail::readInto<typename shared::ArrayRef<E, N>::array_type>(ref, local, snapshot);
}

template <class E, std::size_t N, class Local>
inline void writeBack(const shared::ArrayRef<E, N> &ref, const Local &local, const Local &snapshot) noexcept {
    detail::writeFrom<typename shared::ArrayRef<E, N>::array_type>(ref, local, snapshot);
}

// ---- a whole value (the generated start() writes initial values with it) -------------------------

// Writes all of `value` into the variable: copyIn's counterpart without a snapshot, every word written.
template <class Ref, class Local>
inline void store(const Ref &ref, const Local &value) noexcept {
    Local unlike;
    const auto *from = reinterpret_cast<const unsigned char *>(&value);
    auto *to = reinterpret_cast<unsigned char *>(&unlike);
    for (std::size_t i = 0; i < sizeof(Local); ++i) to[i] = static_cast<unsigned char>(~from[i]);
    writeBack(ref, value, unlike);
}

}  // namespace irp::st
