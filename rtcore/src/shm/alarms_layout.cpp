// alarms_layout.cpp -- the alarm segment ("/indurop.<instance>.alarms", <indurop/alarms.h>)
// described field by field for --print-shm-layout.
#include "shm/describe.hpp"

#include <indurop/alarms.h>

namespace irp::shm {

IRP_SHM_TYPE_NAME(indurop_alarm_header, "indurop_alarm_header");
IRP_SHM_TYPE_NAME(indurop_alarm_source, "indurop_alarm_source");
IRP_SHM_TYPE_NAME(indurop_alarm_record, "indurop_alarm_record");

namespace {

using H = indurop_alarm_header;
constexpr Field kHeader[] = {
    IRP_SHM_FIELD(H, magic, "the bytes IRPALRM1; stored last at creation"),
    IRP_SHM_FIELD(H, version, "the segment's format version"),
    IRP_SHM_FIELD(H, header_size, "bytes of this header"),
    IRP_SHM_FIELD(H, total_size, "bytes of the segment"),
    IRP_SHM_FIELD(H, capacity, "records in the ring, a power of two"),
    IRP_SHM_FIELD(H, record_size, "bytes of one indurop_alarm_record"),
    IRP_SHM_FIELD(H, source_size, "bytes of one indurop_alarm_source"),
    IRP_SHM_FIELD(H, source_max, "sources: 1 (irpd) + the most modules a set may hold"),
    IRP_SHM_FIELD(H, rate_limit, "records one source may write per second; more are counted in rate_dropped"),
    IRP_SHM_FIELD(H, sources_offset, "the sources, indurop_alarm_source[source_max], from the segment's start"),
    IRP_SHM_FIELD(H, records_offset, "the ring, indurop_alarm_record[capacity], from the segment's start"),
    IRP_SHM_FIELD(H, owner_pid, "the irpd that created the segment"),
    IRP_SHM_FIELD(H, reserved1, "zero"),
    IRP_SHM_FIELD(H, head,
                  "the last sequence number claimed (atomic fetch_add by every writer); 0 = none yet. Record s "
                  "sits at index s % capacity"),
    IRP_SHM_FIELD(H, reserved2, "zero; head has the cache line to itself"),
};
IRP_SHM_DESCRIBES(indurop_alarm_header, kHeader);

using S = indurop_alarm_source;
constexpr Field kSource[] = {
    IRP_SHM_FIELD(S, name,
                  "the module's name (\"irpd\" for source 0), NUL-terminated; \"\" = unused. Written by irpd "
                  "before generation"),
    IRP_SHM_FIELD(S, generation,
                  "> 0 while in use, 0 while unused or being given; a new value whenever irpd gives the source to "
                  "a module (release-stored after the name)"),
    IRP_SHM_FIELD(S, declared,
                  "bitmap: bit id set = alarm id is declared for this source (irpd and irp::declareAlarm)"),
    IRP_SHM_FIELD(S, active,
                  "bitmap: bit id set = alarm id is active now (atomic fetch_or / fetch_and by its writers)"),
    IRP_SHM_FIELD(S, recorded, "records written (atomic)"),
    IRP_SHM_FIELD(S, rate_dropped, "transitions not recorded: over rate_limit in their second (atomic)"),
    IRP_SHM_FIELD(S, undeclared, "transitions of ids not declared: recorded with the undeclared flag (atomic)"),
    IRP_SHM_FIELD(S, bad_ids, "calls with an id of 0 or over id_max: refused (atomic)"),
    IRP_SHM_FIELD(S, truncated, "detail texts cut to text_chars - 1 bytes (atomic)"),
    IRP_SHM_FIELD(S, collided,
                  "records not written: their ring slot was held by a writer a lap apart (atomic); the bitmap "
                  "still changed"),
    IRP_SHM_FIELD(S, window_ns, "the rate limiter: when the current second began, CLOCK_REALTIME ns (writers)"),
    IRP_SHM_FIELD(S, window_count, "the rate limiter: records claimed in that second (writers)"),
    IRP_SHM_FIELD(S, reserved, "zero"),
};
IRP_SHM_DESCRIBES(indurop_alarm_source, kSource);

using R = indurop_alarm_record;
constexpr Field kRecord[] = {
    IRP_SHM_FIELD(R, seq,
                  "s, release-stored last; 0 = never written or being written. A copy is intact when seq reads s "
                  "before (acquire) and after it (after an acquire fence)"),
    IRP_SHM_FIELD(R, time_ns, "CLOCK_REALTIME ns when it was raised or cleared"),
    IRP_SHM_FIELD(R, cycle, "the writer's dispatcher cycle (irp::cycle().count); 0 outside run()"),
    IRP_SHM_FIELD(R, source_generation, "the source's generation when it was written: which module wrote it"),
    IRP_SHM_FIELD(R, source, "0 = irpd, else a module's source"),
    IRP_SHM_FIELD(R, id, "the alarm, 1 .. id_max"),
    IRP_SHM_FIELD(R, action, "indurop_alarm_action"),
    IRP_SHM_FIELD(R, severity, "indurop_alarm_severity; declared (0): the one declared for the id"),
    IRP_SHM_FIELD(R, flags, "indurop_alarm_flags, or-ed"),
    IRP_SHM_FIELD(R, reserved0, "zero"),
    IRP_SHM_FIELD(R, value, "a number that goes with it (an error count, an error code); 0 if none"),
    IRP_SHM_FIELD(R, text, "the detail, UTF-8, NUL-terminated; \"\" if none"),
};
IRP_SHM_DESCRIBES(indurop_alarm_record, kRecord);

constexpr Struct kStructs[] = {
    describe<H>("At offset 0; head is on a cache line of its own", kHeader),
    describe<S>("At sources_offset + source x source_size; source 0 is irpd, the others the running set's modules "
                "(docs/alarms.md)",
                kSource),
    describe<R>("At records_offset + (s % capacity) x record_size: record s of the ring", kRecord),
};

constexpr Constant kConstants[] = {
    {"id_max", INDUROP_ALARM_ID_MAX, "alarm ids run from 1 to id_max per source"},
    {"bitmap_words", INDUROP_ALARM_BITMAP_WORDS, "u64 words of declared and active: bit id % 64 of word id / 64"},
    {"text_chars", INDUROP_ALARM_TEXT_CHARS, "bytes of a record's text, NUL included"},
    {"name_chars", INDUROP_ALARM_NAME_CHARS, "bytes of a source's name, NUL included"},
};

constexpr Constant kActions[] = {
    {"clear", INDUROP_ALARM_CLEAR, "the condition is gone"},
    {"raise", INDUROP_ALARM_RAISE, "the condition is there"},
};
constexpr Constant kSeverities[] = {
    {"declared", INDUROP_ALARM_DECLARED, "the severity declared for the id (module.xml, irp::declareAlarm)"},
    {"low", INDUROP_ALARM_LOW, "low"},
    {"medium", INDUROP_ALARM_MEDIUM, "medium"},
    {"high", INDUROP_ALARM_HIGH, "high"},
    {"critical", INDUROP_ALARM_CRITICAL, "critical"},
};
constexpr Constant kFlags[] = {
    {"undeclared", INDUROP_ALARM_UNDECLARED, "the id is not declared for its source"},
    {"truncated", INDUROP_ALARM_TRUNCATED, "the detail text was cut"},
};

constexpr Enum kEnums[] = {
    {"indurop_alarm_action", "indurop_alarm_record.action", kActions},
    {"indurop_alarm_severity", "indurop_alarm_record.severity", kSeverities},
    {"indurop_alarm_flags", "bits of indurop_alarm_record.flags", kFlags},
};

}  // namespace

const Segment &alarmsSegment() {
    static constexpr Segment segment{
        "alarms",
        "/indurop.<instance>.alarms",
        "Modules' alarms: [header][indurop_alarm_source x source_max][indurop_alarm_record x capacity], each part on "
        "a 64-byte boundary. Many writers (libindurop's irp::raiseAlarm and irp::clearAlarm in every module), any "
        "number of readers, nobody waits: the protocol is <indurop/alarms.h>'s (docs/alarms.md).",
        INDUROP_ALARMS_MAGIC,
        INDUROP_ALARMS_VERSION,
        TypeName<H>::value,
        kStructs,
        kConstants,
        kEnums};
    return segment;
}

}  // namespace irp::shm
