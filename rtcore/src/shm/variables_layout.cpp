// variables_layout.cpp -- the shared-variable segment ("/indurop.<instance>.vars",
// <indurop/segment.h>, <indurop/shared.h>) described field by field for --print-shm-layout.
#include "shm/describe.hpp"

#include <indurop/segment.h>
#include <indurop/shared.h>

namespace irp::shm {

IRP_SHM_TYPE_NAME(indurop_segment_header, "indurop_segment_header");
IRP_SHM_TYPE_NAME(indurop_var_lock, "indurop_var_lock");

namespace {

using H = indurop_segment_header;
constexpr Field kHeader[] = {
    IRP_SHM_FIELD(H, magic, "the bytes IRPVARS1"),
    IRP_SHM_FIELD(H, version, "the segment's format version"),
    IRP_SHM_FIELD(H, header_size, "bytes of this header"),
    IRP_SHM_FIELD(H, layout_hash, "SHA-256 (hex) of the layout published last, NUL-terminated; read under layout_seq"),
    IRP_SHM_FIELD(H, total_size, "bytes of the segment"),
    IRP_SHM_FIELD(H, locks_offset, "the lock table: lock_capacity indurop_var_lock, from the segment's start"),
    IRP_SHM_FIELD(H, lock_count, "locks the published layout uses (one per top-level variable); read under layout_seq"),
    IRP_SHM_FIELD(H, lock_size, "bytes of one lock-table entry"),
    IRP_SHM_FIELD(H, layout_offset, "the published layout.json text, from the segment's start; read under layout_seq"),
    IRP_SHM_FIELD(H, layout_size, "bytes of that text (not NUL-terminated); read under layout_seq"),
    IRP_SHM_FIELD(H, data_offset,
                  "the data area, from the segment's start; a variable's layout offset counts from here"),
    IRP_SHM_FIELD(H, data_size, "bytes of the data area the published layout uses; read under layout_seq"),
    IRP_SHM_FIELD(H, owner_pid, "the irpd that created the segment"),
    IRP_SHM_FIELD(H, layout_seq,
                  "even: the layout fields are stable; odd: a new layout is being published. "
                  "Readers copy the layout fields and retry when it was odd or moved meanwhile"),
    IRP_SHM_FIELD(H, lock_capacity, "locks initialised in the lock table (lock_count <= lock_capacity)"),
    IRP_SHM_FIELD(H, layout_capacity, "bytes of each of the two halves of the layout text area"),
    IRP_SHM_FIELD(H, data_capacity, "bytes of the data area (data_size <= data_capacity)"),
    IRP_SHM_FIELD(H, reserved, "zero"),
};
IRP_SHM_DESCRIBES(indurop_segment_header, kHeader);

using L = indurop_var_lock;
constexpr Field kLock[] = {
    IRP_SHM_FIELD(L, mutex, "the variable's writers' lock: priority inheritance, process-shared, robust"),
    IRP_SHM_FIELD(L, seq,
                  "seqlock sequence: even while stable, odd while a writer is inside. A reader copies "
                  "the value between two equal even reads of it"),
};
IRP_SHM_DESCRIBES(indurop_var_lock, kLock);

constexpr Struct kStructs[] = {
    describe<H>("At offset 0", kHeader),
    describe<L>("One per top-level variable, at locks_offset + lock x lock_size", kLock),
};

constexpr Constant kConstants[] = {
    {"layout_hash_chars", INDUROP_LAYOUT_HASH_CHARS, "hex characters of layout_hash"},
};

}  // namespace

const Segment &variablesSegment() {
    static constexpr Segment segment{
        "variables",
        "/indurop.<instance>.vars",
        "The shared variables of the running set: [header][lock table][layout text: 2 x layout_capacity][data], "
        "each part on a 64-byte boundary. The data area is laid out as the published layout.json says.",
        INDUROP_SEGMENT_MAGIC,
        INDUROP_SEGMENT_VERSION,
        TypeName<H>::value,
        kStructs,
        kConstants,
        {}};
    return segment;
}

}  // namespace irp::shm
