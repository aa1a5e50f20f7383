/* control.h -- the control segment through which irpd releases process modules every period and
 * learns when they are done ("/indurop.<instance>.ctl").
 *
 *   [indurop_control_header][indurop_process_slot x slot_count]
 *
 * One slot per process module of the set (periodic, sporadic or non-real), in module.xml order.
 * irpd starts each process with these environment variables:
 *   INDUROP_CTL     the control segment's shm name        INDUROP_SLOT    the process's slot index
 *   INDUROP_SHM     the shared-variable segment (if any)  INDUROP_MODULE  the module's name
 *
 * The handshake, all through futexes on 32-bit words of the slot (no signals):
 *   process: irp::initPeriodExe()   -> state = READY
 *   irpd:    release: cycle/planned_ns/release_ns written, then release_seq += 1, FUTEX_WAKE
 *   process: irp::waitPeriod() returns when release_seq moved past what it last saw (FUTEX_WAIT);
 *            state = RUNNING while it works
 *   process: next irp::waitPeriod() first reports the period done: done_ns written, done_seq =
 *            the release it served, FUTEX_WAKE; state = READY
 *   irpd:    a periodic process is awaited in its slot (FUTEX_WAIT on done_seq, bounded by its
 *            budget, else by what is left of the basic period); a sporadic one is not awaited,
 *            its completion is checked against its deadline at the following basic periods.
 * stop_requested = 1 tells the process to leave (irp::waitPeriod() then returns non-zero).
 */
#ifndef INDUROP_CONTROL_H
#define INDUROP_CONTROL_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define INDUROP_CONTROL_MAGIC 0x314C544350524955ull /* the bytes "UIRPCTL1" */
#define INDUROP_CONTROL_VERSION 1u

enum indurop_process_state {
    INDUROP_PROCESS_EMPTY = 0,    /* not started, or exited and not restarted */
    INDUROP_PROCESS_STARTING = 1, /* forked, initPeriodExe() not called yet */
    INDUROP_PROCESS_READY = 2,    /* waiting in irp::waitPeriod() */
    INDUROP_PROCESS_RUNNING = 3,  /* released, working on its period */
    INDUROP_PROCESS_EXITED = 4,
};

typedef struct indurop_process_slot {
    /* futex words, accessed atomically */
    uint32_t release_seq;    /* irpd: +1 per release */
    uint32_t done_seq;       /* process: the release_seq it finished */
    uint32_t state;          /* enum indurop_process_state */
    uint32_t stop_requested; /* irpd: 1 = leave */
    int32_t pid;
    uint32_t kind;           /* 0 periodic, 1 sporadic, 2 non-real */
    /* what irp::cycle() returns in the process for the current release */
    uint64_t cycle;
    int64_t planned_ns;
    int64_t basic_ns;
    int64_t release_ns;      /* CLOCK_MONOTONIC time of the last release */
    int64_t done_ns;         /* when the process reported the last release done */
    uint64_t generation;     /* +1 each time irpd (re)starts the process */
    char name[64];
    uint8_t reserved[32];
} indurop_process_slot;

typedef struct indurop_control_header {
    uint64_t magic;
    uint32_t version;
    uint32_t header_size;
    uint32_t slot_size;      /* sizeof(indurop_process_slot) */
    uint32_t slot_count;
    int64_t owner_pid;
    uint64_t reserved[4];
} indurop_control_header;

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* INDUROP_CONTROL_H */
