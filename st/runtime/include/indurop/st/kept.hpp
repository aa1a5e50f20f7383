// kept.hpp -- the kept image of a generated module's struct and array variables (its own variables,
// the VAR_GLOBALs and the .glb variables its code touches): image.hpp's copy-in and write-back, with
// the local and its snapshot living on from one run to the next beside `seen`, the variable's lock
// sequence at which both equal the segment's value.  copyIn() then reads only the sequence when no one
// wrote the variable since this module's last copy or write-back (the segment's rule: every write of a
// struct or array, or of any part of one, goes under the variable's lock with the sequence advanced),
// and writeBack() keeps `seen` when it wrote over a value no one else changed meanwhile.  What the
// program sees and writes is as with image.hpp: one consistent read per variable, only the changed
// words written back, a value written from outside during the run kept unless the program changed it.
//
// The variables are one table (Kept, made by kept(); statically initialised, its `seen` written), walked by one loop each way: the
// code of a run stays small however many variables it touches, which is what a run that starts with
// cold caches (every period of a 10 ms task) pays for, line by line.
//
//   Kept image[] = {kept(::main::t1, self.t1, self0.t1), kept(::PLC::IN, in, in0)};
//   copyIn(image);  ... the program ...  writeBack(image);
//
// The generated code also keeps one flag a variable, set where a statement may write it, and calls
// writeBack(image, written): the variables the run did not write cost no comparison.
//
// A lock group (glbc: the struct and array variables of a PROGRAM instance share one lock) is one
// run of entries with that lock, made by grouped(): copyIn() reads the group's sequence once and
// copies the group whole when it moved, writeBack() writes every changed entry of the group under
// one taking of the lock.  A period in which no one else wrote them costs one sequence load for all.
//
//   constinit auto image = grouped(std::array{kept(::main::t1, ...), kept(::main::t2, ...), ...});
//
// After a fault the generated code calls forget(image): the locals hold a partial run.
#pragma once

#include <indurop/shared.h>
#include <indurop/st/image.hpp>

#include <cstdint>
#include <cstring>
#include <algorithm>
#include <array>
#include <span>
#include <type_traits>

namespace irp::st {

// How a changed value is written back (image.hpp's rules): Merge the changed bytes into each word of
// `unit` bytes (a struct, an array of structs), write each changed element of `unit` bytes Whole (an
// array of scalars), or each changed text of `unit` bytes whole (a STRING, an ARRAY OF STRING).
enum class How : uint8_t { Merge, Whole, Texts };

// One variable of the table: 40 bytes, since a run that starts with cold caches reads the table's
// lines (the segment is at most 1 GiB: its offsets fit 32 bits).  The table is written too: `seen` is
// the sequence of the variable's lock (of the group's, on its first entry) at which the local and
// the snapshot equal the segment's value (odd: none; a stable sequence is even).
struct Kept {
    void *local;
    void *snapshot;
    uint32_t offset;  // in the segment (the glbc reference's)
    uint32_t lock;
    uint32_t size;
    uint32_t unit : 30;
    uint32_t how : 2;    // How
    uint32_t group = 1;  // the entries of the lock group that starts here (this one included); 0 in a group
    uint32_t seen = 1;

    How writing() const noexcept { return static_cast<How>(how); }
};
static_assert(sizeof(Kept) == 40);

// kept(ref, local, snapshot); kept(ref, local) for a variable the code never writes (no snapshot,
// never written back).
template <class V, class Local>
constexpr Kept kept(const shared::StructRef<V> &ref, Local &local, Local &snapshot) noexcept {
    static_assert(sizeof(Local) == sizeof(V) && std::is_trivially_copyable_v<Local>,
                  "the local of a shared variable has its size and is plain data");
    constexpr uint32_t unit = alignof(V) >= 8 ? 8 : alignof(V);
    return {&local,        &snapshot, static_cast<uint32_t>(ref.offset()), ref.lockIndex(),
            sizeof(Local), unit,      static_cast<uint32_t>(How::Merge)};
}

template <class E, std::size_t N, class Local>
constexpr Kept kept(const shared::ArrayRef<E, N> &ref, Local &local, Local &snapshot) noexcept {
    using Array = typename shared::ArrayRef<E, N>::array_type;
    using T = typename shared::ArrayRef<E, N>::value_type;
    using Inner = typename detail::Innermost<T>::type;
    static_assert(sizeof(Local) == sizeof(Array) && std::is_trivially_copyable_v<Local>,
                  "the local of a shared variable has its size and is plain data");
    Kept k{&local,        &snapshot, static_cast<uint32_t>(ref.offset()), ref.lockIndex(),
           sizeof(Local), 0,         static_cast<uint32_t>(How::Merge)};
    if constexpr (std::is_same_v<T, char>) {
        k.how = static_cast<uint32_t>(How::Texts), k.unit = static_cast<uint32_t>(N);
    } else if constexpr (std::is_same_v<Inner, char>) {
        k.how = static_cast<uint32_t>(How::Texts), k.unit = static_cast<uint32_t>(sizeof(T));
    } else if constexpr (std::is_arithmetic_v<Inner> || std::is_enum_v<Inner>) {
        k.how = static_cast<uint32_t>(How::Whole), k.unit = static_cast<uint32_t>(sizeof(Inner));
    } else {
        k.unit = alignof(Array) >= 8 ? 8 : static_cast<uint32_t>(alignof(Array));
    }
    return k;
}

template <class Ref, class Local>
constexpr Kept kept(const Ref &ref, Local &local) noexcept {
    Kept k = kept(ref, local, local);
    k.snapshot = nullptr;
    return k;
}

// The table with its lock groups: each run of entries with one lock becomes a group, seen through
// its first entry's `seen`.  A lock in two runs is an error at compile time (the generated code puts a
// group's entries together: the second run would find the sequence moved by the first's write-back).
template <std::size_t N>
consteval std::array<Kept, N> grouped(std::array<Kept, N> table) {
    for (std::size_t i = 0; i < N;) {
        std::size_t end = i + 1;
        while (end < N && table[end].lock == table[i].lock) ++end;
        for (std::size_t j = end; j < N; ++j)
            if (table[j].lock == table[i].lock) throw "a lock group's entries are not together in the table";
        table[i].group = static_cast<uint32_t>(end - i);
        for (std::size_t j = i + 1; j < end; ++j) table[j].group = 0;
        i = end;
    }
    return table;
}

namespace detail {

// One consistent read of the group of n entries at g into their locals and snapshots, unless its
// sequence is still the one seen.
inline void readGroup(Kept *g, std::size_t n) noexcept {
    auto seq = shared::detail::sequence(g->lock);
    uint32_t before = seq.load(std::memory_order_acquire);
    if (before == g->seen) return;
    auto copy = [&] {
        for (std::size_t i = 0; i < n; ++i)
            shared::detail::atomicCopy(g[i].local, indurop_shared_data + g[i].offset, g[i].size);
    };
    auto snapshots = [&] {
        for (std::size_t i = 0; i < n; ++i)
            if (g[i].snapshot != nullptr) std::memcpy(g[i].snapshot, g[i].local, g[i].size);
    };
    for (int attempt = 0; attempt < shared::kSpinReads; ++attempt, before = seq.load(std::memory_order_acquire)) {
        if (before & 1) {
            __builtin_ia32_pause();
            continue;
        }
        copy();
        std::atomic_thread_fence(std::memory_order_acquire);
        if (seq.load(std::memory_order_relaxed) == before) {
            snapshots();
            g->seen = before;
            return;
        }
    }
    shared::lockVariable(g->lock);
    copy();
    g->seen = seq.load(std::memory_order_relaxed);
    shared::unlockVariable(g->lock);
    snapshots();
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

// The changed words, elements or texts of one entry (the caller holds the lock).
inline void mergeKept(const Kept &k) noexcept {
    const auto *l = static_cast<const char *>(k.local), *s = static_cast<const char *>(k.snapshot);
    char *to = indurop_shared_data + k.offset;
    if (k.writing() == How::Merge) {
        mergeUnits<false>(k, to, l, s);
    } else if (k.writing() == How::Whole) {
        mergeUnits<true>(k, to, l, s);
    } else {
        for (uint32_t t = 0; t + k.unit <= k.size; t += k.unit)
            if (!sameBytes(l + t, s + t, k.unit))
                for (uint32_t i = t; i < t + k.unit; ++i) storeLeaf<uint8_t>(to, l, i);
    }
}

inline bool changedKept(const Kept &k) noexcept {
    return k.snapshot != nullptr && std::memcmp(k.local, k.snapshot, k.size) != 0;
}

// The group of n entries at g, of which those with flags[i] may have been written: the changed
// ones (compared with their snapshots; libc's memcmp, vectorised: the sizes vary along the table)
// under the lock, taken once.  Then, when no one else wrote the group since the copy-in (the
// sequence before this write was the one seen), the segment holds the locals: their snapshots
// follow and the new sequence is seen; else the segment mixes two writers' bytes and the next
// copy-in reads the group whole.  Clears the flags (they hold "changed" meanwhile).
inline void writeGroup(Kept *g, std::size_t n, bool *flags, uint32_t &seen) noexcept {
    bool any = false;
    for (std::size_t i = 0; i < n; ++i)
        if (flags[i]) {
            flags[i] = changedKept(g[i]);
            any = any || flags[i];
        }
    if (!any) return;
    uint32_t at = 0;
    shared::detail::writeExclusive(g->lock, [&] {
        at = shared::detail::sequence(g->lock).load(std::memory_order_relaxed);
        for (std::size_t i = 0; i < n; ++i)
            if (flags[i]) mergeKept(g[i]);
    });
    const bool alone = at - 1 == seen;
    for (std::size_t i = 0; i < n; ++i)
        if (flags[i]) {
            flags[i] = false;
            if (alone) std::memcpy(g[i].snapshot, g[i].local, g[i].size);
        }
    seen = alone ? at + 1 : 1;
}

}  // namespace detail

// A table's groups start at 0 and each at the end of the one before (Kept::group: its length).
inline void copyIn(std::span<Kept> image) noexcept {
    for (std::size_t i = 0; i < image.size(); i += image[i].group) detail::readGroup(&image[i], image[i].group);
}

// The variables the run may have written: written[i] is set by the generated code before each
// statement that may write image[i] (an assignment, an FB call on it, a VAR_IN_OUT argument, ...),
// so a variable no statement of this run wrote is not compared with its snapshot (it still equals
// it).  Clears the flags for the next run.
inline void writeBack(std::span<Kept> image, std::span<bool> written) noexcept {
    for (std::size_t i = 0; i < image.size(); i += image[i].group)
        detail::writeGroup(&image[i], image[i].group, &written[i], image[i].seen);
}

// Every variable may have been written.
inline void writeBack(std::span<Kept> image) noexcept {
    for (std::size_t i = 0; i < image.size(); i += image[i].group) {
        bool flags[64];  // a group in pieces of 64 flags: the sequence seen stays right (see writeGroup)
        for (std::size_t at = 0; at < image[i].group; at += 64) {
            const std::size_t n = std::min<std::size_t>(64, image[i].group - at);
            std::fill_n(flags, n, true);
            detail::writeGroup(&image[i] + at, n, flags, image[i].seen);
        }
    }
}

// Runs f, a function of its own: the generated code cuts long runs of copy-ins, write-backs and
// initial values into lambdas run by inPart(), so that g++ compiles them in pieces of a bounded size.
template <class F>
[[gnu::noinline]] void inPart(F &&f) {
    f();
}

// After a run that did not finish: every variable is read whole again.
inline void forget(std::span<Kept> image) noexcept {
    for (Kept &k : image) k.seen = 1;
}

inline void forget(std::span<Kept> image, std::span<bool> written) noexcept {
    forget(image);
    for (bool &w : written) w = false;
}

}  // namespace irp::st
