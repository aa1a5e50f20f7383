/* alarms.h -- the layout of the alarm segment ("/indurop.<instance>.alarms"): modules raise and
 * clear alarms from run() without blocking or allocating; the agent reads them and keeps their
 * states (ISA-18.2: active, acknowledged, cleared, shelved), their history and who acknowledged.
 *
 *   [indurop_alarm_header][indurop_alarm_source x source_max][indurop_alarm_record x capacity]
 *
 * every part starting on a 64-byte boundary, little-endian x86-64.
 *
 * Sources.  Source 0 is irpd itself; every module of the running set has a source of its own,
 * by name: when a set starts, module i takes source 1 + i (module.xml order); a swap keeps a
 * module's source for every module whose name stays (kept or loaded anew), gives a new name the
 * lowest source in use by neither set, and frees the sources of the names it drops once the swap
 * is over (a freed source is all zero, name "" included).  irpd fills a source's name,
 * generation and declared bitmap when it gives the source to a module, and zeroes the rest.  An
 * alarm is (source, id), id 1 .. INDUROP_ALARM_ID_MAX.  Its text and severity are declared in
 * module.xml (<alarm id="8" severity="high">drive communication lost</alarm>) or by the module in
 * initialize() or start() (irp::declareAlarm); irpd answers them with the control command
 * `alarms` (docs/alarms.md).
 *
 * Raising and clearing (irp::raiseAlarm, irp::clearAlarm, irp::alarm; libindurop):
 *   - the source's `active` bitmap says which alarms are active: raising an active alarm, or
 *     clearing one that is not, changes nothing and writes nothing (so a module may call
 *     irp::alarm(id, condition) every period);
 *   - otherwise the bit is flipped (atomic fetch_or / fetch_and) and one record is written, if
 *     the source's rate allows it (at most rate_limit records per second per source; more are
 *     counted in rate_dropped, and the bitmap still changes, so the agent's reconciliation from
 *     the bitmaps finds the state);
 *   - an id over INDUROP_ALARM_ID_MAX is refused and counted (bad_ids); an id not declared is
 *     recorded with INDUROP_ALARM_UNDECLARED and counted (undeclared); a detail text longer than
 *     INDUROP_ALARM_TEXT_CHARS - 1 is cut and flagged INDUROP_ALARM_TRUNCATED.
 *
 * The record ring: many writers (every module's thread and every process module), any number of
 * readers, nobody waits.  A writer claims sequence number s = fetch_add(&head, 1) + 1 and takes
 * the record at index s % capacity by a compare-and-swap of its `seq` from the value the writer
 * of the lap before left there (s - capacity, or 0 on the first lap; an older completed one too)
 * to 0, "being written"; then it writes the record and stores `seq` = s with release.  When the
 * slot holds 0 (another writer is in it) or a later lap's s, the writer leaves it alone: its
 * record is lost, counted in the source's `collided` (the bitmap still changes).  A reader that
 * wants record s copies it after an acquire load of seq == s, then (after an acquire fence) loads
 * seq again: the copy is intact iff both loads gave s.  seq > s: overwritten, the reader lost it
 * (it counts the loss).  seq < s: not written yet; a writer takes microseconds, so a reader that
 * still sees it so once head has moved capacity past s, or a second later, skips it and counts a
 * loss (its writer died in it, or collided).  Times are CLOCK_REALTIME (what operators read) and
 * the writer's dispatcher cycle (0 outside run()).
 */
#ifndef INDUROP_ALARMS_H
#define INDUROP_ALARMS_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define INDUROP_ALARMS_MAGIC 0x314d524c41505249ull /* the bytes "IRPALRM1" */
#define INDUROP_ALARMS_VERSION 1u
#define INDUROP_ALARM_ID_MAX 1023u     /* alarm ids 1 .. 1023 per source */
#define INDUROP_ALARM_BITMAP_WORDS 16u /* 1024 bits: bit id of a bitmap is alarm id */
#define INDUROP_ALARM_TEXT_CHARS 136u  /* a record's detail text, NUL included */
#define INDUROP_ALARM_NAME_CHARS 64u   /* a source's name, NUL included */

/* What a record says happened. */
enum indurop_alarm_action {
    INDUROP_ALARM_CLEAR = 0, /* the condition is gone */
    INDUROP_ALARM_RAISE = 1, /* the condition is there */
};

/* Severity: as declared (0), or given by the call. */
enum indurop_alarm_severity {
    INDUROP_ALARM_DECLARED = 0,
    INDUROP_ALARM_LOW = 1,
    INDUROP_ALARM_MEDIUM = 2,
    INDUROP_ALARM_HIGH = 3,
    INDUROP_ALARM_CRITICAL = 4,
};

/* Record flags. */
#define INDUROP_ALARM_UNDECLARED 1u /* the id is not declared for its source */
#define INDUROP_ALARM_TRUNCATED 2u  /* the detail text was cut */

typedef struct indurop_alarm_record {
    uint64_t seq;               /* s, stored last with release; 0 = never written, or being written */
    int64_t time_ns;            /* CLOCK_REALTIME when it was raised or cleared */
    uint64_t cycle;             /* the writer's dispatcher cycle (irp::cycle().count); 0 outside run() */
    uint64_t source_generation; /* the source's generation when it was written */
    uint32_t source;            /* 0 = irpd, else a module's source (see Sources above) */
    uint32_t id;                /* 1 .. INDUROP_ALARM_ID_MAX */
    uint8_t action;             /* enum indurop_alarm_action */
    uint8_t severity;           /* enum indurop_alarm_severity; 0: the declared one */
    uint16_t flags;             /* INDUROP_ALARM_UNDECLARED | INDUROP_ALARM_TRUNCATED */
    uint32_t reserved0;
    double value;                        /* a number that goes with it (an error count, an error code); 0 if none */
    char text[INDUROP_ALARM_TEXT_CHARS]; /* detail, NUL-terminated; "" if none */
} indurop_alarm_record;

typedef struct indurop_alarm_source {
    char name[INDUROP_ALARM_NAME_CHARS];           /* the module's name ("irpd" for source 0); "" = unused */
    uint64_t generation;                           /* > 0 while in use; changes when another module takes the source */
    uint64_t declared[INDUROP_ALARM_BITMAP_WORDS]; /* ids declared for it (irpd writes them) */
    uint64_t active[INDUROP_ALARM_BITMAP_WORDS];   /* ids active now (atomic fetch_or / fetch_and) */
    /* counters, each atomic */
    uint64_t recorded;     /* records written */
    uint64_t rate_dropped; /* transitions not recorded: over rate_limit in their second */
    uint64_t undeclared;   /* transitions of ids not declared (recorded, flagged) */
    uint64_t bad_ids;      /* calls with an id of 0 or over INDUROP_ALARM_ID_MAX (refused) */
    uint64_t truncated;    /* detail texts cut */
    uint64_t collided;     /* records not written: their ring slot was held by a writer a lap apart */
    /* the rate limiter: records claimed in the second that began at window_ns (atomic) */
    int64_t window_ns;
    uint64_t window_count;
    uint64_t reserved[7];
} indurop_alarm_source;

typedef struct indurop_alarm_header {
    /* fixed when irpd creates the segment */
    uint64_t magic;
    uint32_t version;
    uint32_t header_size; /* sizeof(indurop_alarm_header) */
    uint64_t total_size;
    uint64_t capacity;    /* records in the ring, a power of two */
    uint32_t record_size; /* sizeof(indurop_alarm_record) */
    uint32_t source_size; /* sizeof(indurop_alarm_source) */
    uint32_t source_max;  /* sources: 1 + the most modules a set may hold */
    uint32_t rate_limit;  /* records per second per source */
    uint64_t sources_offset;
    uint64_t records_offset;
    int64_t owner_pid; /* the irpd that created it */
    uint64_t reserved1[7];
    /* written by every writer */
    uint64_t head; /* the last sequence number claimed (atomic fetch_add); 0 = none yet */
    uint64_t reserved2[7];
} indurop_alarm_header;

#ifdef __cplusplus
} /* extern "C" */

// Readers in other languages take every offset from irpd's description of these structs
// (`irpd --print-shm-layout`, docs/shared-memory.md), which a test keeps current.
#include <cstddef>
static_assert(sizeof(indurop_alarm_record) % 64 == 0, "alarm records fill whole cache lines");
static_assert(sizeof(indurop_alarm_source) % 64 == 0, "alarm sources fill whole cache lines");
static_assert(offsetof(indurop_alarm_header, head) % 64 == 0 && sizeof(indurop_alarm_header) % 64 == 0,
              "alarm header: head on a cache line of its own");
#endif /* __cplusplus */

#endif /* INDUROP_ALARMS_H */
