// forces.hpp -- the force table the dispatchers apply (docs/forcing.md): each forced leaf's place in
// the data area and its forced bytes.  The control thread builds a new table (allocating, off the
// RT threads) and publishes it with one atomic pointer store; a table is immutable once published.
// Each executor loads the current table at the start of each slot and notes its generation
// (Executor::forceSeen); an old table is freed only once every executor noted a newer one.  The
// RT side (apply) takes no lock unless it writes, allocates nothing and makes no system call.
#pragma once

#include <indurop/shared.h>

#include <atomic>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <vector>

namespace irp::dispatch {

struct ForcedLeaf {
    uint64_t offset = 0;  // in the data area
    uint32_t size = 0;    // 1, 2, 4 or 8
    uint32_t lock = 0;    // its top-level variable's lock
    alignas(8) unsigned char value[8] = {};
};

struct ForceTable {
    uint64_t generation = 0;  // 1 for the first (empty) table, +1 per publication
    std::vector<ForcedLeaf> leaves;
};

// Whether the leaf at `place` holds f's value: one relaxed atomic load of its width.
template <class W>
inline bool holds(const char *place, const ForcedLeaf &f) noexcept {
    W forced;
    std::memcpy(&forced, f.value, sizeof forced);
    return __atomic_load_n(reinterpret_cast<const W *>(place), __ATOMIC_RELAXED) == forced;
}

// The leaf's bytes are its forced value, or made so as a writer of it does (its lock and sequence,
// libindurop's writeExclusive), so that readers of the whole variable stay consistent.  Only a
// compare when nobody wrote it since the last application.
inline void applyForce(const ForcedLeaf &f) noexcept {
    char *place = indurop_shared_data + f.offset;
    const bool same = f.size == 8   ? holds<uint64_t>(place, f)
                      : f.size == 4 ? holds<uint32_t>(place, f)
                      : f.size == 2 ? holds<uint16_t>(place, f)
                                    : holds<uint8_t>(place, f);
    if (same) return;
    shared::detail::writeExclusive(f.lock, [&] { shared::detail::atomicCopy(place, f.value, f.size); });
}

inline void applyForces(const ForceTable *table) noexcept {
    if (!table) return;
    for (const ForcedLeaf &f : table->leaves) applyForce(f);
}

// The published table and the ones retired, not yet freed.  publish() and reclaim(): any non-RT
// thread (serialized inside); current(): any thread.
class ForceBoard {
public:
    ForceBoard();
    const ForceTable *current() const noexcept { return current_.load(std::memory_order_acquire); }
    // Publishes `leaves` as the next table; returns its generation.
    uint64_t publish(std::vector<ForcedLeaf> leaves);
    // Frees the retired tables older than `oldest_seen` (the oldest generation an executor may
    // still read: Dispatcher::forcesSeen).
    void reclaim(uint64_t oldest_seen);
    std::size_t retired() const;

private:
    mutable std::mutex mutex_;
    std::unique_ptr<ForceTable> owned_;
    std::vector<std::unique_ptr<ForceTable>> retired_;
    std::atomic<const ForceTable *> current_{nullptr};
};

}  // namespace irp::dispatch
