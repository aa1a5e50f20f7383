// kept.hpp -- the kept image of a generated module's struct and array variables (its own variables,
// the VAR_GLOBALs and the .glb variables its code touches): image.hpp's copy-in and write-back, with
// the local and its snapshot living on from one run to the next beside a Seen, the variable's lock
// sequence at which both equal the segment's value.  copyIn() then reads only the sequence when no one
// wrote the variable since this module's last copy or write-back (the segment's rule: every write of a
// struct or array, or of any part of one, goes under the variable's lock with the sequence advanced),
// and writeBack() keeps the Seen when it wrote over a value no one else changed meanwhile.  What the
// program sees and writes is as with image.hpp: one consistent read per variable, only the changed
// words written back, a value written from outside during the run kept unless the program changed it.
//
// The variables are one constant table (Kept, made by kept()), walked by one loop each way: the
// code of a run stays small however many variables it touches, which is what a run that starts with
// cold caches (every period of a 10 ms task) pays for, line by line.
//
//   Seen seen[2];
//   constexpr Kept image[] = {kept(::main::t1, self.t1, self0.t1, seen[0]), kept(::PLC::IN, in, in0, seen[1])};
//   copyIn(image);  ... the program ...  writeBack(image);
//
// The generated code also keeps one flag a variable, set where a statement may write it, and calls
// writeBack(image, written): the variables the run did not write cost no comparison.
//
// After a fault the generated code calls forget(image): the locals hold a partial run.
#pragma once

#include <indurop/shared.h>
#include <indurop/st/image.hpp>

#include <cstdint>
#include <cstring>
#include <span>
#include <type_traits>

namespace irp::st {

// The sequence of a variable's lock at which a kept local and its snapshot equal the segment's value
// (odd: none; a stable sequence is even).
struct Seen {
    uint32_t seq = 1;
};

// How a changed value is written back (image.hpp's rules): Merge the changed bytes into each word of
// `unit` bytes (a struct, an array of structs), write each changed element of `unit` bytes Whole (an
// array of scalars), or each changed text of `unit` bytes whole (a STRING, an ARRAY OF STRING).
enum class How : uint8_t { Merge, Whole, Texts };

// One variable of the table.
struct Kept {
    uint64_t offset;  // in the segment (the glbc reference's)
    uint32_t lock;
    uint32_t size;
    void *local;
    void *snapshot;
    Seen *seen;
    uint32_t unit;
    How how;
};

// kept(ref, local, snapshot, seen); kept(ref, local, seen) for a variable the code never writes (no
// snapshot, never written back).
template <class V, class Local>
constexpr Kept kept(const shared::StructRef<V> &ref, Local &local, Local &snapshot, Seen &seen) noexcept {
    static_assert(sizeof(Local) == sizeof(V) && std::is_trivially_copyable_v<Local>,
                  "the local of a shared variable has its size and is plain data");
    constexpr uint32_t unit = alignof(V) >= 8 ? 8 : alignof(V);
    return {ref.offset(), ref.lockIndex(), sizeof(Local), &local, &snapshot, &seen, unit, How::Merge};
}

template <class E, std::size_t N, class Local>
constexpr Kept kept(const shared::ArrayRef<E, N> &ref, Local &local, Local &snapshot, Seen &seen) noexcept {
    using Array = typename shared::ArrayRef<E, N>::array_type;
    using T = typename shared::ArrayRef<E, N>::value_type;
    using Inner = typename detail::Innermost<T>::type;
    static_assert(sizeof(Local) == sizeof(Array) && std::is_trivially_copyable_v<Local>,
                  "the local of a shared variable has its size and is plain data");
    Kept k{ref.offset(), ref.lockIndex(), sizeof(Local), &local, &snapshot, &seen, 0, How::Merge};
    if constexpr (std::is_same_v<T, char>) {
        k.how = How::Texts, k.unit = static_cast<uint32_t>(N);
    } else if constexpr (std::is_same_v<Inner, char>) {
        k.how = How::Texts, k.unit = static_cast<uint32_t>(sizeof(T));
    } else if constexpr (std::is_arithmetic_v<Inner> || std::is_enum_v<Inner>) {
        k.how = How::Whole, k.unit = static_cast<uint32_t>(sizeof(Inner));
    } else {
        k.unit = alignof(Array) >= 8 ? 8 : static_cast<uint32_t>(alignof(Array));
    }
    return k;
}

template <class Ref, class Local>
constexpr Kept kept(const Ref &ref, Local &local, Seen &seen) noexcept {
    Kept k = kept(ref, local, local, seen);
    k.snapshot = nullptr;
    return k;
}

namespace detail {

// One consistent read into local and snapshot, unless the sequence is still the one seen.
inline void readKept(const Kept &k) noexcept {
    auto seq = shared::detail::sequence(k.lock);
    uint32_t before = seq.load(std::memory_order_acquire);
    if (before == k.seen->seq) return;
    const char *from = indurop_shared_data + k.offset;
    for (int attempt = 0; attempt < shared::kSpinReads; ++attempt, before = seq.load(std::memory_order_acquire)) {
        if (before & 1) {
            __builtin_ia32_pause();
            continue;
        }
        shared::detail::atomicCopy(k.local, from, k.size);
        std::atomic_thread_fence(std::memory_order_acquire);
        if (seq.load(std::memory_order_relaxed) == before) {
            if (k.snapshot != nullptr) std::memcpy(k.snapshot, k.local, k.size);
            k.seen->seq = before;
            return;
        }
    }
    shared::lockVariable(k.lock);
    shared::detail::atomicCopy(k.local, from, k.size);
    k.seen->seq = seq.load(std::memory_order_relaxed);
    shared::unlockVariable(k.lock);
    if (k.snapshot != nullptr) std::memcpy(k.snapshot, k.local, k.size);
}

template <bool Whole>
inline void mergeUnits(const Kept &k, char *to, const char *l, const char *s) noexcept {
    switch (k.unit) {
    case 8: mergeWords<uint64_t, Whole>(to, l, s, k.size); break;
    case 4: mergeWords<uint32_t, Whole>(to, l, s, k.size); break;
    case 2: mergeWords<uint16_t, Whole>(to, l, s, k.size); break;
    default: mergeWords<uint8_t, Whole>(to, l, s, k.size); break;
    }
}

// The changed words, elements or texts under the variable's lock; then, when no one else wrote since
// the copy-in (the sequence before this write was the one seen), the segment holds the local: the
// snapshot follows it and the new sequence is seen; else the segment mixes two writers' bytes and the
// next copy-in reads it whole.
inline void writeKept(const Kept &k) noexcept {
    if (k.snapshot == nullptr) return;  // read only
    const auto *l = static_cast<const char *>(k.local), *s = static_cast<const char *>(k.snapshot);
    if (std::memcmp(l, s, k.size) == 0) return;  // libc's, vectorised: the sizes vary along the table
    uint32_t at = 0;
    shared::detail::writeExclusive(k.lock, [&] {
        at = shared::detail::sequence(k.lock).load(std::memory_order_relaxed);
        char *to = indurop_shared_data + k.offset;
        if (k.how == How::Merge) {
            mergeUnits<false>(k, to, l, s);
        } else if (k.how == How::Whole) {
            mergeUnits<true>(k, to, l, s);
        } else {
            for (uint32_t t = 0; t + k.unit <= k.size; t += k.unit)
                if (!sameBytes(l + t, s + t, k.unit))
                    for (uint32_t i = t; i < t + k.unit; ++i) storeLeaf<uint8_t>(to, l, i);
        }
    });
    if (at - 1 == k.seen->seq) {
        std::memcpy(k.snapshot, k.local, k.size);
        k.seen->seq = at + 1;
    } else {
        k.seen->seq = 1;
    }
}

}  // namespace detail

inline void copyIn(std::span<const Kept> image) noexcept {
    for (const Kept &k : image) detail::readKept(k);
}

inline void writeBack(std::span<const Kept> image) noexcept {
    for (const Kept &k : image) detail::writeKept(k);
}

// The variables the run may have written: written[i] is set by the generated code before each
// statement that may write image[i] (an assignment, an FB call on it, a VAR_IN_OUT argument, ...),
// so a variable no statement of this run wrote is not compared with its snapshot (it still equals
// it).  Clears the flags for the next run.
inline void writeBack(std::span<const Kept> image, std::span<bool> written) noexcept {
    for (std::size_t i = 0; i < image.size(); ++i)
        if (written[i]) {
            written[i] = false;
            detail::writeKept(image[i]);
        }
}

// Runs f, a function of its own: the generated code cuts long runs of copy-ins, write-backs and
// initial values into lambdas run by inPart(), so that g++ compiles them in pieces of a bounded size.
template <class F>
[[gnu::noinline]] void inPart(F &&f) {
    f();
}

// After a run that did not finish: every variable is read whole again.
inline void forget(std::span<const Kept> image) noexcept {
    for (const Kept &k : image) k.seen->seq = 1;
}

inline void forget(std::span<const Kept> image, std::span<bool> written) noexcept {
    forget(image);
    for (bool &w : written) w = false;
}

}  // namespace irp::st
