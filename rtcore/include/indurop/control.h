/* control.h -- the control segment through which irpd releases process modules every period and
 * learns when they are done ("/indurop.<instance>.ctl").
 *
 *   [indurop_control_header][indurop_process_slot x slot_count][indurop_function_entry x function_count]
 *
 * One slot per process module of the set (periodic, sporadic or non-real), in module.xml order.
 * irpd starts each process with these environment variables:
 *   INDUROP_CTL     the control segment's shm name        INDUROP_SLOT    the process's slot index
 *   INDUROP_SHM     the shared-variable segment (if any)  INDUROP_MODULE  the module's name
 *
 * The handshake, all through futexes on 32-bit words of the slot (no signals):
 *   process: irp::initPeriodExe()   -> state = READY
 *   irpd:    release: cycle/planned_ns/release_ns/next_due_ns written, then release_seq += 1;
 *            FUTEX_WAKE unless the process's wake_ns says it wakes by itself by then (below)
 *   process: irp::waitPeriod() returns when release_seq moved past what it last saw, and only then;
 *            state = RUNNING while it works
 *   The process's wait for its next release (FUTEX_WAIT_BITSET on release_seq): first until
 *   next_due_ns, the due time of its next release (wake_ns = that time, stored before the wait),
 *   so that at that time it is already runnable when its dispatcher blocks; if the release has not
 *   come when it wakes, on without a timeout (wake_ns = 0).  irpd stores release_seq, then reads
 *   wake_ns (both seq_cst, against the process's store of wake_ns and its read of release_seq):
 *   0, or a time after the release, and it makes the FUTEX_WAKE; a time at or before the release
 *   means the process's own timer has expired, so the wake is left out (docs/process-modules.md).
 *   process: next irp::waitPeriod() first reports the period done: done_ns written, done_seq =
 *            the release it served, FUTEX_WAKE; state = READY
 *   irpd:    a periodic process is awaited in its slot (FUTEX_WAIT on done_seq, bounded by its
 *            budget, else by what is left of the basic period: irpd's watchdog thread wakes the
 *            wait at that bound, docs/process-modules.md); a sporadic one is not awaited,
 *            its completion is checked against its deadline at the following basic periods.
 * A release made ahead (docs/process-modules.md): a periodic process first in its slot is released
 * by its dispatcher just before the dispatcher sleeps until the slot's due time, with release_at_ns
 * = that due time.  The process runs it only once release_at_ns has passed, and claims it first by
 * a compare-and-swap of release_at_ns to 0 (writing started_ns): irpd may, until then, take it back
 * with the same compare-and-swap, to 0 (run it now: the process is woken as for any release) or to
 * INDUROP_RELEASE_CANCELLED (the process reports it done without running it).  release_at_ns = 0:
 * an ordinary release, run at once.
 * stop_requested = 1 tells the process to leave (irp::waitPeriod() then returns non-zero).
 *
 * Shared functions called from processes (<indurop/functions.h>, docs/shared-variables.md):
 * the function table lists every function the thread modules exported (sorted by name); irpd
 * writes it once, after every module's start() and before any process starts, and never changes
 * it while it runs.  Each slot has one call area: a process has at most one call in flight.
 * Its futex word `word` is (tag << 2) | phase, tag = the request's number:
 *   process: IDLE -> writes function, signature_hash, sizes, args -> PENDING (tag + 1)
 *   irpd:    right after the owning module's run(), in its slot: PENDING -> SERVING (CAS from
 *            the exact word, so a request cancelled and replaced is never taken for the old one)
 *            -> status, result -> ANSWERED, FUTEX_WAKE
 *   process: FUTEX_WAIT on word until ANSWERED (bounded by its timeout); reads status and result
 *            -> IDLE.  On timeout it cancels with the CAS PENDING -> IDLE; a request already
 *            SERVING is left to finish and its answer is dropped by the next call.
 */
#ifndef INDUROP_CONTROL_H
#define INDUROP_CONTROL_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define INDUROP_CONTROL_MAGIC 0x314C544350524955ull /* the bytes "UIRPCTL1" */
#define INDUROP_CONTROL_VERSION 3u                  /* 2: call areas and the function table; 3: releases made ahead */
/* release_at_ns of a release made ahead that irpd took back: reported done, not run */
#define INDUROP_RELEASE_CANCELLED INT64_MAX

enum indurop_process_state {
    INDUROP_PROCESS_EMPTY = 0,    /* not started, or exited and not restarted */
    INDUROP_PROCESS_STARTING = 1, /* forked, initPeriodExe() not called yet */
    INDUROP_PROCESS_READY = 2,    /* waiting in irp::waitPeriod() */
    INDUROP_PROCESS_RUNNING = 3,  /* released, working on its period */
    INDUROP_PROCESS_EXITED = 4,
};

/* Shared-function calls ------------------------------------------------------------------- */

#define INDUROP_CALL_BYTES 256u         /* packed arguments, and the result, at most */
#define INDUROP_FUNCTION_NAME_CHARS 96u /* names of 96 characters or more are not listed */
#define INDUROP_FUNCTION_SIGNATURE_CHARS 160u

enum indurop_call_phase {
    INDUROP_CALL_IDLE = 0,
    INDUROP_CALL_PENDING = 1,  /* written by the process, not taken yet */
    INDUROP_CALL_SERVING = 2,  /* irpd is calling the function */
    INDUROP_CALL_ANSWERED = 3, /* status (and result) written */
};
#define INDUROP_CALL_PHASE(word) ((word)&3u)
#define INDUROP_CALL_TAG(word) ((word) >> 2)

/* What a call came to (irp::lastCallStatus()).  irpd answers OK, SIGNATURE_MISMATCH,
 * BAD_REQUEST, OWNER_DISABLED, NOT_TRANSFERABLE or THREW; the others are found by the process. */
enum indurop_call_status {
    INDUROP_CALL_OK = 0,
    INDUROP_CALL_UNKNOWN_FUNCTION = 1,   /* no function of that name in the table */
    INDUROP_CALL_SIGNATURE_MISMATCH = 2, /* the caller's R(A...) is not the export's */
    INDUROP_CALL_TOO_LARGE = 3,          /* arguments or result over INDUROP_CALL_BYTES */
    INDUROP_CALL_TIMEOUT = 4,            /* no answer within the caller's timeout */
    INDUROP_CALL_OWNER_DISABLED = 5,     /* the owner threw from run() and is disabled */
    INDUROP_CALL_NOT_SERVED = 6,         /* the owner is not a periodic thread module */
    INDUROP_CALL_NOT_TRANSFERABLE = 7,   /* the export takes or returns pointers, references or
                                            non-trivially-copyable types */
    INDUROP_CALL_THREW = 8,              /* the function threw; result holds what() */
    INDUROP_CALL_NO_IRPD = 9,            /* not started by irpd, or its control segment unusable */
    INDUROP_CALL_STOPPED = 10,           /* irpd stopped serving calls (it is stopping) */
    INDUROP_CALL_BAD_REQUEST = 11,       /* irpd: index or sizes do not match the export */
    INDUROP_CALL_INVALID = 12,           /* bad arguments to the call itself (timeout <= 0, no name) */
};

/* enum values of indurop_control_header.calls */
enum indurop_calls_state {
    INDUROP_CALLS_NONE = 0,    /* no table yet */
    INDUROP_CALLS_SERVING = 1, /* the table is published; requests are served */
    INDUROP_CALLS_STOPPED = 2, /* the dispatcher stopped: nothing will be served any more */
};

typedef struct indurop_call_area {
    uint32_t word;           /* futex: (tag << 2) | enum indurop_call_phase */
    uint32_t function;       /* request: index in the function table */
    uint64_t signature_hash; /* request: FNV-1a 64 of the caller's typeid(R(A...)).name() */
    uint32_t args_size;      /* request: packed argument bytes */
    uint32_t result_size;    /* request: result bytes expected */
    int32_t status;          /* answer: enum indurop_call_status */
    uint32_t reserved0;
    uint64_t served_cycle;              /* answer: the owner executor's basic-period count when served */
    uint8_t args[INDUROP_CALL_BYTES];   /* the arguments, back to back in order, no padding */
    uint8_t result[INDUROP_CALL_BYTES]; /* the result's bytes; THREW: the message, 0-terminated */
} indurop_call_area;

typedef struct indurop_function_entry {
    char name[INDUROP_FUNCTION_NAME_CHARS];
    char signature[INDUROP_FUNCTION_SIGNATURE_CHARS]; /* typeid name, cut if longer (the hash is of all of it) */
    char owner[64];          /* the exporting module ("" if exported outside a lifecycle call) */
    uint64_t signature_hash; /* FNV-1a 64 of the whole typeid name */
    int64_t owner_period_ns; /* 0 when the owner has no period (sporadic) */
    uint32_t owner_index;    /* the owner's index in module.xml, UINT32_MAX: none */
    uint32_t refusal;        /* 0: callable from processes; else the enum indurop_call_status why not */
    uint32_t args_size;      /* packed argument bytes */
    uint32_t result_size;
} indurop_function_entry;

/* Process slots ------------------------------------------------------------------------------ */

typedef struct indurop_process_slot {
    /* futex words, accessed atomically */
    uint32_t release_seq;    /* irpd: +1 per release */
    uint32_t done_seq;       /* process: the release_seq it finished */
    uint32_t state;          /* enum indurop_process_state */
    uint32_t stop_requested; /* irpd: 1 = leave */
    int32_t pid;
    uint32_t kind; /* 0 periodic, 1 sporadic, 2 non-real */
    /* what irp::cycle() returns in the process for the current release */
    uint64_t cycle;
    int64_t planned_ns;
    int64_t basic_ns;
    int64_t release_ns;  /* CLOCK_MONOTONIC time of the last release */
    int64_t done_ns;     /* when the process reported the last release done */
    uint64_t generation; /* +1 each time irpd (re)starts the process */
    char name[64];
    int64_t next_due_ns;    /* irpd, at a release: when the process's next release is due (0: unknown) */
    int64_t wake_ns;        /* process: its wait for a release ends by itself at this time; 0: only a wake ends it */
    int64_t release_at_ns;  /* irpd: the release starts no sooner (a release made ahead); 0: at once; claimed: 0 */
    int64_t started_ns;     /* process: when it started its last release */
    indurop_call_area call; /* this process's calls of shared functions */
} indurop_process_slot;

typedef struct indurop_control_header {
    uint64_t magic;
    uint32_t version;
    uint32_t header_size;
    uint32_t slot_size; /* sizeof(indurop_process_slot) */
    uint32_t slot_count;
    int64_t owner_pid;
    uint64_t function_offset; /* of the function table, from the segment's start */
    uint32_t function_count;
    uint32_t function_size; /* sizeof(indurop_function_entry) */
    uint32_t calls;         /* enum indurop_calls_state */
    uint32_t call_bytes;    /* INDUROP_CALL_BYTES */
    uint64_t reserved[2];
} indurop_control_header;

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* INDUROP_CONTROL_H */
