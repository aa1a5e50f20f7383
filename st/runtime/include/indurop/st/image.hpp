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
// segment's rule for top-level scalars).  An array of scalars writes each changed element whole, an
// array of chars (a STRING) its whole text.  A struct (or an array of structs) is compared byte by
// byte; each aligned word of the value's alignment (at most 8 bytes, so no leaf straddles two) that
// holds a changed byte is rewritten as one atomic store that merges the changed bytes into the word
// read under the lock.  So a leaf the program did not change keeps what another writer put there
// during the run.  A leaf that both the program and another writer changed in the same run gets
// the program's changed bytes over the other writer's value; to write such a leaf whole, give
// writeBack() the value's leaves (offset and size of each scalar, from the layout): then each
// changed leaf is written whole, as one atomic store.
//
// kept.hpp keeps locals and snapshots from one run to the next, so that a variable no one else
// wrote is not read again (the image the generated run() uses).
//
// Also the cycle time: cycleTime() is the due time of the period in progress, the time base of
// TON, TOF and TP.  None of these allocates or makes a system call (an uncontended lock is a CAS).
#pragma once

#include <indurop/indurop.h>
#include <indurop/shared.h>
#include <indurop/st/types.hpp>

#include <array>
#include <cstdint>
#include <cstring>
#include <span>
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

// A scalar the code only reads: no snapshot.
template <class T>
inline void copyIn(const shared::ScalarRef<T> &ref, T &local) noexcept {
    local = ref.load();
}

template <class T>
inline void writeBack(const shared::ScalarRef<T> &ref, const T &local, const T &snapshot) noexcept {
    if (std::memcmp(&local, &snapshot, sizeof(T)) != 0) ref.store(local);
}

namespace detail {

// Whether n bytes are equal: word by word, inline (n is a constant where it is called, so the loop
// unrolls; a call of memcmp per variable costs more than the comparison of a few words).
inline bool sameBytes(const void *a, const void *b, std::size_t n) noexcept {
    const auto *x = static_cast<const char *>(a), *y = static_cast<const char *>(b);
    uint64_t diff = 0;
    std::size_t at = 0;
    for (; at + 8 <= n; at += 8) {
        uint64_t u, v;
        std::memcpy(&u, x + at, 8);
        std::memcpy(&v, y + at, 8);
        diff |= u ^ v;
    }
    for (; at < n; ++at) diff |= static_cast<uint64_t>(static_cast<unsigned char>(x[at] ^ y[at]));
    return diff == 0;
}

// 0xff in each byte of w that is not zero.
template <class W>
constexpr W byteMask(W w) noexcept {
    constexpr W ones = static_cast<W>(static_cast<W>(~W{0}) / 0xff);  // 0x01 in each byte
    W m = static_cast<W>(w | (w >> 4));
    m = static_cast<W>(m | (m >> 2));
    m = static_cast<W>((m | (m >> 1)) & ones);
    return static_cast<W>(m * 0xff);
}

// Whole: each word is one leaf (an array of scalars), written whole when it changed; else the
// changed bytes are merged into the word as it is now.
template <class W, bool Whole>
inline void mergeWords(char *shared, const char *local, const char *snapshot, std::size_t size) noexcept {
    for (std::size_t at = 0; at < size; at += sizeof(W)) {
        W l, s;
        std::memcpy(&l, local + at, sizeof(W));
        std::memcpy(&s, snapshot + at, sizeof(W));
        const W diff = static_cast<W>(l ^ s);
        if (diff == 0) continue;
        if constexpr (Whole) {
            __atomic_store_n(reinterpret_cast<W *>(shared + at), l, __ATOMIC_RELAXED);
            continue;
        }
        const W mask = byteMask(diff);
        W *cell = reinterpret_cast<W *>(shared + at);
        const W now = __atomic_load_n(cell, __ATOMIC_RELAXED);
        __atomic_store_n(cell, static_cast<W>((now & static_cast<W>(~mask)) | (l & mask)), __ATOMIC_RELAXED);
    }
}

// The changed words of `size` bytes at ref's place, under its lock; Align: the value's alignment.
template <std::size_t Align, bool Whole = false>
inline void writeChanged(const shared::RefBase &ref, const void *local, const void *snapshot,
                         std::size_t size) noexcept {
    if (sameBytes(local, snapshot, size)) return;
    const auto *l = static_cast<const char *>(local), *s = static_cast<const char *>(snapshot);
    shared::detail::writeExclusive(ref.lockIndex(), [&] {
        char *to = ref.address();
        if constexpr (Align >= 8)
            mergeWords<uint64_t, Whole>(to, l, s, size);
        else if constexpr (Align == 4)
            mergeWords<uint32_t, Whole>(to, l, s, size);
        else if constexpr (Align == 2)
            mergeWords<uint16_t, Whole>(to, l, s, size);
        else
            mergeWords<uint8_t, Whole>(to, l, s, size);
    });
}

}  // namespace detail

// One leaf of a struct or array value: a scalar of 1, 2, 4 or 8 bytes at its natural alignment, or
// a run of bytes written whole (a STRING's char[n+1]).  The generator emits a constexpr table of a
// variable's leaves from its layout.
struct Leaf {
    uint32_t offset;
    uint32_t size;
};

namespace detail {

template <class W>
inline void storeLeaf(char *shared, const char *local, std::size_t offset) noexcept {
    W v;
    std::memcpy(&v, local + offset, sizeof(W));
    __atomic_store_n(reinterpret_cast<W *>(shared + offset), v, __ATOMIC_RELAXED);
}

// The changed leaves, each whole, under the variable's lock.
inline void writeLeaves(const shared::RefBase &ref, const void *local, const void *snapshot, std::size_t size,
                        std::span<const Leaf> leaves) noexcept {
    if (sameBytes(local, snapshot, size)) return;
    const auto *l = static_cast<const char *>(local), *s = static_cast<const char *>(snapshot);
    shared::detail::writeExclusive(ref.lockIndex(), [&] {
        char *to = ref.address();
        for (const Leaf &leaf : leaves) {
            if (leaf.offset + leaf.size > size || std::memcmp(l + leaf.offset, s + leaf.offset, leaf.size) == 0)
                continue;
            switch (leaf.size) {
            case 1: storeLeaf<uint8_t>(to, l, leaf.offset); break;
            case 2: storeLeaf<uint16_t>(to, l, leaf.offset); break;
            case 4: storeLeaf<uint32_t>(to, l, leaf.offset); break;
            case 8: storeLeaf<uint64_t>(to, l, leaf.offset); break;
            default:
                for (uint32_t i = 0; i < leaf.size; ++i) storeLeaf<uint8_t>(to, l, leaf.offset + i);
                break;
            }
        }
    });
}

// The scalar type inside nested std::arrays (the element of a multi-dimensional array).
template <class T>
struct Innermost {
    using type = T;
};
template <class U, std::size_t M>
struct Innermost<std::array<U, M>> : Innermost<U> {};

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

// The same, writing each changed leaf whole (see Leaf).
template <class V, class Local>
inline void writeBack(const shared::StructRef<V> &ref, const Local &local, const Local &snapshot,
                      std::span<const Leaf> leaves) noexcept {
    static_assert(sizeof(Local) == sizeof(V) && std::is_trivially_copyable_v<Local>,
                  "the local of a shared variable has its size and is plain data");
    detail::writeLeaves(ref, &local, &snapshot, sizeof(Local), leaves);
}

// ---- arrays (Local: std::array of the elements, nested for more dimensions, or a C array) -------

template <class E, std::size_t N, class Local>
inline void copyIn(const shared::ArrayRef<E, N> &ref, Local &local, Local &snapshot) noexcept {
    detail::readInto<typename shared::ArrayRef<E, N>::array_type>(ref, local, snapshot);
}

// An array of scalars (of any dimensions) writes each changed element whole; an array of chars (a
// STRING's char[n+1]) the whole text when any of it changed, an array of them each changed text
// whole; an array of structs merges the changed bytes as a struct does.
template <class E, std::size_t N, class Local>
inline void writeBack(const shared::ArrayRef<E, N> &ref, const Local &local, const Local &snapshot) noexcept {
    using Array = typename shared::ArrayRef<E, N>::array_type;
    using T = typename shared::ArrayRef<E, N>::value_type;
    static_assert(sizeof(Local) == sizeof(Array) && std::is_trivially_copyable_v<Local>,
                  "the local of a shared variable has its size and is plain data");
    using Inner = typename detail::Innermost<T>::type;
    if constexpr (std::is_same_v<T, char>) {
        const Leaf whole[] = {{0, static_cast<uint32_t>(N)}};
        detail::writeLeaves(ref, &local, &snapshot, sizeof(Local), whole);
    } else if constexpr (std::is_same_v<Inner, char>) {  // ARRAY OF STRING: each text is a leaf
        static constexpr auto texts = [] {
            std::array<Leaf, N> leaves{};
            for (std::size_t i = 0; i < N; ++i)
                leaves[i] = {static_cast<uint32_t>(i * sizeof(T)), static_cast<uint32_t>(sizeof(T))};
            return leaves;
        }();
        detail::writeLeaves(ref, &local, &snapshot, sizeof(Local), texts);
    } else if constexpr (std::is_arithmetic_v<Inner> || std::is_enum_v<Inner>) {  // every dimension
        detail::writeChanged<sizeof(Inner), true>(ref, &local, &snapshot, sizeof(Local));
    } else {
        detail::writeFrom<Array>(ref, local, snapshot);
    }
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
