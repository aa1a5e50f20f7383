/* trace.h -- the layout of the trace rings ("/indurop.<instance>.trace"): every basic period irpd's
 * main dispatcher samples up to 64 shared variables into rings that other processes read.
 *
 *   [indurop_trace_header][indurop_trace_config x 2][u64 seq[capacity]][i64 t_ns[capacity]]
 *   [double values[channel_max][capacity]]   (channel-major: channel c's ring is contiguous)
 *
 * every part starting on a 64-byte boundary, little-endian x86-64.  One row per basic period:
 * seq (1, 2, 3, ...), the CLOCK_MONOTONIC due time of the period, and the value of each channel of
 * the configuration in force, converted to double.  Row `seq` sits at index seq % capacity of
 * every ring.
 *
 * Single writer (the RT sampler), any number of readers, nobody waits:
 *   - the sampler writes row s, then stores head = s with release;
 *   - a reader loads head (acquire), copies rows, then (after an acquire fence) loads head again:
 *     with that second value h, the rows it copied are intact iff seq > h + 1 - capacity (the
 *     sampler may be writing row h + 1 meanwhile).  So at most capacity - 1 rows are readable.
 * The channel configuration is double-buffered: the control thread writes the config that is not
 * in force, then asks for it (pending_config); the sampler takes it at its next period, records
 * the first seq sampled with it in first_seq and config_seq, and publishes config_generation.
 * A config is read like a seqlock: its `generation` is 0 while the control thread rewrites it.
 * docs/trace-and-stream.md describes the protocol, docs/shared-memory.md every field (from
 * `irpd --print-shm-layout`).
 */
#ifndef INDUROP_TRACE_H
#define INDUROP_TRACE_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define INDUROP_TRACE_MAGIC 0x3143415254505249ull /* the bytes "IRPTRAC1" */
#define INDUROP_TRACE_VERSION 1u
#define INDUROP_TRACE_CHANNELS 64       /* channels per configuration */
#define INDUROP_TRACE_PATH_CHARS 232    /* a channel's path, NUL included */
#define INDUROP_TRACE_NO_SEQ UINT64_MAX /* first_seq of a config not (yet) in force */

/* How a channel's variable is stored in the variables segment (its value in the rings is a double). */
enum indurop_trace_type {
    INDUROP_TRACE_NONE = 0,
    INDUROP_TRACE_FLOAT32 = 1,
    INDUROP_TRACE_FLOAT64 = 2,
    INDUROP_TRACE_INT8 = 3,
    INDUROP_TRACE_INT16 = 4,
    INDUROP_TRACE_INT32 = 5,
    INDUROP_TRACE_INT64 = 6,
    INDUROP_TRACE_UINT8 = 7,
    INDUROP_TRACE_UINT16 = 8,
    INDUROP_TRACE_UINT32 = 9,
    INDUROP_TRACE_UINT64 = 10,
    INDUROP_TRACE_BOOL = 11
};

/* One traced variable: a scalar leaf of the shared-variable layout. */
typedef struct indurop_trace_channel {
    char path[INDUROP_TRACE_PATH_CHARS]; /* "knu.Robot.joints[0].x", NUL-terminated */
    uint64_t offset;                     /* bytes into the variables segment's data area */
    uint32_t type;                       /* enum indurop_trace_type */
    uint32_t lock;                       /* lock (seqlock) index of its top-level variable */
    uint32_t size;                       /* bytes: 1, 2, 4 or 8 */
    uint32_t reserved;
} indurop_trace_channel;

/* One of the two channel configurations.  Values column c of a row sampled with this config is
 * channels[c]. */
typedef struct indurop_trace_config {
    uint64_t generation;    /* > 0; 0 while the control thread rewrites this config (retry) */
    uint64_t first_seq;     /* the first row sampled with it; INDUROP_TRACE_NO_SEQ until then */
    uint32_t channel_count; /* 0..INDUROP_TRACE_CHANNELS */
    uint32_t reserved0;
    uint64_t reserved[5];
    indurop_trace_channel channels[INDUROP_TRACE_CHANNELS];
} indurop_trace_config;

typedef struct indurop_trace_header {
    /* fixed when irpd creates the segment */
    uint64_t magic;
    uint32_t version;
    uint32_t header_size; /* sizeof(indurop_trace_header) */
    uint64_t total_size;
    uint64_t capacity;     /* rows per ring, a power of two */
    uint32_t channel_max;  /* INDUROP_TRACE_CHANNELS */
    uint32_t channel_size; /* sizeof(indurop_trace_channel) */
    uint32_t config_size;  /* sizeof(indurop_trace_config) */
    uint32_t reserved0;
    uint64_t configs_offset; /* indurop_trace_config[2] */
    uint64_t seq_offset;     /* uint64_t[capacity]: the seq of the row at each index */
    uint64_t time_offset;    /* int64_t[capacity]: CLOCK_MONOTONIC due time of its basic period, ns */
    uint64_t values_offset;  /* double[channel_max][capacity] */
    int64_t owner_pid;       /* the irpd that created it */
    int64_t basic_period_ns; /* (atomic) the sampling period; irpd updates it when a swap changes it */
    uint64_t reserved1[4];
    /* written by the sampler (the RT thread), each with an atomic store */
    uint64_t head;              /* seq of the newest complete row; 0 = none yet (release-stored) */
    uint64_t config_generation; /* generation of the config in force */
    uint64_t config_seq;        /* the first seq sampled with it */
    uint32_t active_config;     /* 0 or 1: the config in force */
    uint32_t reserved2;
    uint64_t torn_skips; /* samples that took a channel's previous value: a writer stayed inside */
    uint64_t reserved3[3];
    /* written by the control thread and taken by the sampler (atomic exchange) */
    uint32_t pending_config; /* 0: nothing asked; 1 + index of the config to put in force */
    uint32_t reserved4;
    uint64_t reserved5[7];
} indurop_trace_header;

#ifdef __cplusplus
} /* extern "C" */

// Readers in other languages take every offset from irpd's description of these structs
// (`irpd --print-shm-layout`, docs/shared-memory.md), which a test keeps current.
#include <cstddef>
// The sampler's fields on a cache line of their own, the control thread's on the next (the last).
static_assert(offsetof(indurop_trace_header, head) % 64 == 0 &&
                  offsetof(indurop_trace_header, pending_config) == offsetof(indurop_trace_header, head) + 64 &&
                  sizeof(indurop_trace_header) == offsetof(indurop_trace_header, pending_config) + 64,
              "trace header: one cache line for the sampler, one for the control thread");
#endif

#endif /* INDUROP_TRACE_H */
