/* segment.h -- the header of the shared-variable segment ("/indurop.<instance>.vars").
 *
 * irpd creates the segment from a layout.json (written by glbc) before it loads any module:
 *
 *   [indurop_segment_header][lock table: lock_capacity locks][layout text: 2 x layout_capacity][data]
 *
 * every part starting on a 64-byte boundary.  The segment is made larger than its first layout
 * (docs/shared-variables.md, "Layouts that evolve"): an online change publishes a layout that
 * adds variables in the free room without remapping.  Publishing writes the new text into the
 * half of the text area not in use, then changes hash, layout_offset, layout_size, lock_count
 * and data_size between two increments of layout_seq (odd while it writes): a reader takes
 * layout_seq, copies those fields and the text, and retries when layout_seq was odd or moved.  Thread modules see it through libindurop in
 * irpd's own process; process modules and the agent map it (the agent read-only) and check
 * magic, version and layout_hash before using it.  The data area is laid out exactly as the
 * layout says (offsets relative to data_offset); the layout text lets a process resolve a
 * variable by its path ("knu.Robot.joints[1].y") without having been compiled against it.
 */
#ifndef INDUROP_SEGMENT_H
#define INDUROP_SEGMENT_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define INDUROP_SEGMENT_MAGIC 0x3153524156505249ull /* the bytes "IRPVARS1" */
#define INDUROP_SEGMENT_VERSION 2u
#define INDUROP_LAYOUT_HASH_CHARS 64 /* sha256 in hex */

typedef struct indurop_segment_header {
    uint64_t magic;
    uint32_t version;
    uint32_t header_size;
    char layout_hash[INDUROP_LAYOUT_HASH_CHARS + 8]; /* NUL-terminated */
    uint64_t total_size;
    uint64_t locks_offset;
    uint32_t lock_count;
    uint32_t lock_size; /* sizeof(indurop_var_lock) */
    uint64_t layout_offset;
    uint64_t layout_size; /* bytes of layout.json text, not NUL-terminated */
    uint64_t data_offset;
    uint64_t data_size;
    int64_t owner_pid;        /* the irpd that created it */
    uint32_t layout_seq;      /* even: the layout fields above are stable; odd: being published */
    uint32_t lock_capacity;   /* locks initialised in the lock table (lock_count <= lock_capacity) */
    uint64_t layout_capacity; /* bytes of each of the two halves of the text area */
    uint64_t data_capacity;   /* bytes of the data area (data_size <= data_capacity) */
    uint64_t reserved[5];
} indurop_segment_header;

#ifdef __cplusplus
} /* extern "C" */

// Readers in other languages take every offset from irpd's description of this header
// (`irpd --print-shm-layout`, docs/shared-memory.md), which a test keeps current.

#include <atomic>
#include <cstring>
#include <string>
#include <sched.h>

namespace irp::segment {

// The hash and text of the layout published last, copied consistently (the reader's side of
// layout_seq).  Allocates: not for an RT thread.
inline void copyLayout(const indurop_segment_header *h, std::string &hash, std::string &text) {
    hash.clear();
    text.clear();
    if (!h) return;
    auto *header = const_cast<indurop_segment_header *>(h);
    std::atomic_ref<uint32_t> seq(header->layout_seq);
    const char *base = reinterpret_cast<const char *>(h);
    for (;;) {
        const uint32_t before = seq.load(std::memory_order_acquire);
        if (before & 1) {
            sched_yield();
            continue;
        }
        const uint64_t offset = std::atomic_ref<uint64_t>(header->layout_offset).load(std::memory_order_relaxed);
        const uint64_t size = std::atomic_ref<uint64_t>(header->layout_size).load(std::memory_order_relaxed);
        if (offset + size <= h->total_size) {
            hash.assign(h->layout_hash, strnlen(h->layout_hash, INDUROP_LAYOUT_HASH_CHARS));
            text.assign(base + offset, size);
        }
        std::atomic_thread_fence(std::memory_order_acquire);
        if (seq.load(std::memory_order_relaxed) == before) return;
    }
}

}  // namespace irp::segment
#endif

#endif /* INDUROP_SEGMENT_H */
