/* segment.h -- the header of the shared-variable segment ("/indurop.<instance>.vars").
 *
 * irpd creates the segment from a layout.json (written by glbc) before it loads any module:
 *
 *   [indurop_segment_header][lock table: lock_count x indurop_var_lock][layout.json text][data]
 *
 * every part starting on a 64-byte boundary.  Thread modules see it through libindurop in
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
#define INDUROP_SEGMENT_VERSION 1u
#define INDUROP_LAYOUT_HASH_CHARS 64 /* sha256 in hex */

typedef struct indurop_segment_header {
    uint64_t magic;
    uint32_t version;
    uint32_t header_size;
    char layout_hash[INDUROP_LAYOUT_HASH_CHARS + 8]; /* NUL-terminated */
    uint64_t total_size;
    uint64_t locks_offset;
    uint32_t lock_count;
    uint32_t lock_size;   /* sizeof(indurop_var_lock) */
    uint64_t layout_offset;
    uint64_t layout_size; /* bytes of layout.json text, not NUL-terminated */
    uint64_t data_offset;
    uint64_t data_size;
    int64_t owner_pid;    /* the irpd that created it */
    uint64_t reserved[8];
} indurop_segment_header;

#ifdef __cplusplus
} /* extern "C" */

// Readers in other languages (the agent) use these offsets; they are part of the format.
#include <cstddef>
static_assert(offsetof(indurop_segment_header, layout_hash) == 16, "segment header layout");
static_assert(offsetof(indurop_segment_header, locks_offset) == 96, "segment header layout");
static_assert(offsetof(indurop_segment_header, lock_size) == 108, "segment header layout");
static_assert(offsetof(indurop_segment_header, layout_offset) == 112, "segment header layout");
static_assert(offsetof(indurop_segment_header, data_offset) == 128, "segment header layout");
#endif

#endif /* INDUROP_SEGMENT_H */
