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
//
// Generated code walks the table made compact (KeptImage, below: 20 bytes an entry, the groups apart).
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

// The table a run walks (what generated code declares): the entries of `spec` (a grouped() table,
// constexpr: pointers to the module's locals) made compact, 20 bytes a row (the local and its
// snapshot as offsets from one base, within the module's data), the groups apart, 16 bytes each
// (lock, sequence seen, first row, rows).  A run that starts with cold caches reads the rows of
// the entries it flagged and the groups: 9 lines for the 24 entries of the plc-robot cell, where
// 40-byte entries were 15.  The rows' offsets are taken from the spec at the first copyIn().
//
//   constexpr auto spec = grouped(std::array{kept(...), ...});
//   constinit KeptImage<spec.size(), groupCount(spec)> image{spec};
//   copyIn(image);  ... the program ...  writeBack(image, written);
struct KeptRow {
    int32_t local;     // from KeptImage::base
    int32_t snapshot;  // likewise; kNoSnapshot: the code only reads the variable
    uint32_t offset;   // in the segment
    uint32_t size;
    uint32_t unit : 30;
    uint32_t how : 2;
};
static_assert(sizeof(KeptRow) == 20);

struct KeptGroup {
    uint32_t lock;
    uint32_t seen;  // as Kept::seen
    uint32_t first;
    uint32_t count;
};

inline constexpr int32_t kNoSnapshot = INT32_MIN;

template <std::size_t N>
consteval std::size_t groupCount(const std::array<Kept, N> &spec) {
    std::size_t g = 0;
    for (std::size_t i = 0; i < N; i += spec[i].group) ++g;
    return g;
}

template <std::size_t N, std::size_t G>
struct KeptImage {
    const Kept *spec;      // the constexpr table, read at the first copyIn()
    char *base = nullptr;  // null until then
    std::array<KeptGroup, G> groups{};
    std::array<KeptRow, N> rows{};

    consteval explicit KeptImage(const std::array<Kept, N> &table) : spec(table.data()) {
        for (std::size_t i = 0, g = 0; i < N; i += table[i].group, ++g)
            groups[g] = {table[i].lock, 1, static_cast<uint32_t>(i), table[i].group};
        for (std::size_t i = 0; i < N; ++i)
            rows[i] = {0, kNoSnapshot, table[i].offset, table[i].size, table[i].unit, table[i].how};
    }

    // The locals' and snapshots' offsets from the first local (a module's data is well within 2 GiB).
    [[gnu::cold]] void bind() noexcept {
        char *at = static_cast<char *>(spec[0].local);
        for (std::size_t i = 0; i < N; ++i) {
            rows[i].local = static_cast<int32_t>(static_cast<char *>(spec[i].local) - at);
            if (spec[i].snapshot != nullptr)
                rows[i].snapshot = static_cast<int32_t>(static_cast<char *>(spec[i].snapshot) - at);
        }
        base = at;
    }
};

namespace detail {

// One entry as the group routines see it, from a Kept or a KeptRow.
struct Entry {
    char *local;
    char *snapshot;  // null: read only
    uint32_t offset;
    uint32_t size;
    uint32_t unit;
    How how;
};

inline Entry entry(const Kept &k) noexcept {
    return {static_cast<char *>(k.local), static_cast<char *>(k.snapshot), k.offset, k.size, k.unit, k.writing()};
}

inline Entry entry(const KeptRow &r, char *base) noexcept {
    return {base + r.local,         r.snapshot == kNoSnapshot ? nullptr : base + r.snapshot, r.offset, r.size, r.unit,
            static_cast<How>(r.how)};
}

// One consistent read of the group of n entries (at(i): the i-th) into their locals and
// snapshots, unless its sequence is still the one seen.
template <class At>
inline void readGroup(At at, std::size_t n, uint32_t lock, uint32_t &seen) noexcept {
    auto seq = shared::detail::sequence(lock);
    uint32_t before = seq.load(std::memory_order_acquire);
    if (before == seen) return;
    auto copy = [&] {
        for (std::size_t i = 0; i < n; ++i) {
            const Entry e = at(i);
            shared::detail::atomicCopy(e.local, indurop_shared_data + e.offset, e.size);
        }
    };
    auto snapshots = [&] {
        for (std::size_t i = 0; i < n; ++i) {
            const Entry e = at(i);
            if (e.snapshot != nullptr) std::memcpy(e.snapshot, e.local, e.size);
        }
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
            seen = before;
            return;
        }
    }
    shared::lockVariable(lock);
    copy();
    seen = seq.load(std::memory_order_relaxed);
    shared::unlockVariable(lock);
    snapshots();
}

template <bool Whole>
inline void mergeUnits(const Entry &k, char *to, const char *l, const char *s) noexcept {
    switch (k.unit) {
    case 8: mergeWords<uint64_t, Whole>(to, l, s, k.size); break;
    case 4: mergeWords<uint32_t, Whole>(to, l, s, k.size); break;
    case 2: mergeWords<uint16_t, Whole>(to, l, s, k.size); break;
    default: mergeWords<uint8_t, Whole>(to, l, s, k.size); break;
    }
}

// The changed words, elements or texts of one entry (the caller holds the lock).
inline void mergeKept(const Entry &k) noexcept {
    const char *l = k.local, *s = k.snapshot;
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
}

inline bool changedKept(const Entry &k) noexcept {
    return k.snapshot != nullptr && std::memcmp(k.local, k.snapshot, k.size) != 0;
}

// The group of n entries, of which those with flags[i] may have been written: the changed ones
// (compared with their snapshots; libc's memcmp, vectorised: the sizes vary along the table)
// under the lock, taken once.  Then, when no one else wrote the group since the copy-in (the
// sequence before this write was the one seen), the segment holds the locals: their snapshots
// follow and the new sequence is seen; else the segment mixes two writers' bytes and the next
// copy-in reads the group whole.  Clears the flags (they hold "changed" meanwhile).
template <class At>
inline void writeGroup(At at, std::size_t n, bool *flags, uint32_t lock, uint32_t &seen) noexcept {
    bool any = false;
    for (std::size_t i = 0; i < n; ++i)
        if (flags[i]) {
            flags[i] = changedKept(at(i));
            any = any || flags[i];
        }
    if (!any) return;
    uint32_t now = 0;
    shared::detail::writeExclusive(lock, [&] {
        now = shared::detail::sequence(lock).load(std::memory_order_relaxed);
        for (std::size_t i = 0; i < n; ++i)
            if (flags[i]) mergeKept(at(i));
    });
    const bool alone = now - 1 == seen;
    for (std::size_t i = 0; i < n; ++i)
        if (flags[i]) {
            flags[i] = false;
            if (alone) {
                const Entry e = at(i);
                std::memcpy(e.snapshot, e.local, e.size);
            }
        }
    seen = alone ? now + 1 : 1;
}

inline auto entries(Kept *g) noexcept {
    return [g](std::size_t i) { return entry(g[i]); };
}

}  // namespace detail

// A table's groups start at 0 and each at the end of the one before (Kept::group: its length).
inline void copyIn(std::span<Kept> image) noexcept {
    for (std::size_t i = 0; i < image.size(); i += image[i].group)
        detail::readGroup(detail::entries(&image[i]), image[i].group, image[i].lock, image[i].seen);
}

// The variables the run may have written: written[i] is set by the generated code before each
// statement that may write image[i] (an assignment, an FB call on it, a VAR_IN_OUT argument, ...),
// so a variable no statement of this run wrote is not compared with its snapshot (it still equals
// it).  Clears the flags for the next run.
inline void writeBack(std::span<Kept> image, std::span<bool> written) noexcept {
    for (std::size_t i = 0; i < image.size(); i += image[i].group)
        detail::writeGroup(detail::entries(&image[i]), image[i].group, &written[i], image[i].lock, image[i].seen);
}

// Every variable may have been written.
inline void writeBack(std::span<Kept> image) noexcept {
    for (std::size_t i = 0; i < image.size(); i += image[i].group) {
        bool flags[64];  // a group in pieces of 64 flags: the sequence seen stays right (see writeGroup)
        for (std::size_t at = 0; at < image[i].group; at += 64) {
            const std::size_t n = std::min<std::size_t>(64, image[i].group - at);
            std::fill_n(flags, n, true);
            detail::writeGroup(detail::entries(&image[i] + at), n, flags, image[i].lock, image[i].seen);
        }
    }
}

// The same on the compact table.
template <std::size_t N, std::size_t G>
inline void copyIn(KeptImage<N, G> &image) noexcept {
    if (image.base == nullptr) [[unlikely]]
        image.bind();
    char *base = image.base;
    for (KeptGroup &g : image.groups) {
        const KeptRow *rows = &image.rows[g.first];
        detail::readGroup([=](std::size_t i) { return detail::entry(rows[i], base); }, g.count, g.lock, g.seen);
    }
}

template <std::size_t N, std::size_t G>
inline void writeBack(KeptImage<N, G> &image, bool (&written)[N]) noexcept {
    char *base = image.base;
    for (KeptGroup &g : image.groups) {
        const KeptRow *rows = &image.rows[g.first];
        detail::writeGroup([=](std::size_t i) { return detail::entry(rows[i], base); }, g.count, &written[g.first],
                           g.lock, g.seen);
    }
}

template <std::size_t N, std::size_t G>
inline void forget(KeptImage<N, G> &image) noexcept {
    for (KeptGroup &g : image.groups) g.seen = 1;
}

template <std::size_t N, std::size_t G>
inline void forget(KeptImage<N, G> &image, bool (&written)[N]) noexcept {
    forget(image);
    for (bool &w : written) w = false;
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
