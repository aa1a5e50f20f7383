// control_layout.cpp -- the control segment ("/indurop.<instance>.ctl", <indurop/control.h>):
// process slots, their call areas and the shared-function table, described for --print-shm-layout.
#include "shm/describe.hpp"

#include <indurop/control.h>

namespace irp::shm {

IRP_SHM_TYPE_NAME(indurop_control_header, "indurop_control_header");
IRP_SHM_TYPE_NAME(indurop_process_slot, "indurop_process_slot");
IRP_SHM_TYPE_NAME(indurop_call_area, "indurop_call_area");
IRP_SHM_TYPE_NAME(indurop_function_entry, "indurop_function_entry");

namespace {

using H = indurop_control_header;
constexpr Field kHeader[] = {
    IRP_SHM_FIELD(H, magic, "the bytes UIRPCTL1"),
    IRP_SHM_FIELD(H, version, "the segment's format version"),
    IRP_SHM_FIELD(H, header_size, "bytes of this header; the slots follow it"),
    IRP_SHM_FIELD(H, slot_size, "bytes of one indurop_process_slot"),
    IRP_SHM_FIELD(H, slot_count, "process slots"),
    IRP_SHM_FIELD(H, owner_pid, "the irpd that created the segment"),
    IRP_SHM_FIELD(H, function_offset, "the function table, from the segment's start"),
    IRP_SHM_FIELD(H, function_count, "entries in the function table"),
    IRP_SHM_FIELD(H, function_size, "bytes of one indurop_function_entry"),
    IRP_SHM_FIELD(H, calls, "enum indurop_calls_state"),
    IRP_SHM_FIELD(H, call_bytes, "bytes of a call's arguments, and of its result, at most"),
    IRP_SHM_FIELD(H, reserved, "zero"),
};
IRP_SHM_DESCRIBES(indurop_control_header, kHeader);

using S = indurop_process_slot;
constexpr Field kSlot[] = {
    IRP_SHM_FIELD(S, release_seq, "futex: irpd adds 1 per release"),
    IRP_SHM_FIELD(S, done_seq, "futex: the release_seq the process finished"),
    IRP_SHM_FIELD(S, state, "enum indurop_process_state"),
    IRP_SHM_FIELD(S, stop_requested, "irpd: 1 = leave"),
    IRP_SHM_FIELD(S, pid, "the process, 0 when none"),
    IRP_SHM_FIELD(S, kind, "0 periodic, 1 sporadic, 2 non-real"),
    IRP_SHM_FIELD(S, cycle, "what irp::cycle() returns in the process for the current release"),
    IRP_SHM_FIELD(S, planned_ns, "the release's planned time"),
    IRP_SHM_FIELD(S, basic_ns, "the basic period"),
    IRP_SHM_FIELD(S, release_ns, "CLOCK_MONOTONIC time of the last release"),
    IRP_SHM_FIELD(S, done_ns, "when the process reported the last release done"),
    IRP_SHM_FIELD(S, generation, "+1 each time irpd (re)starts the process"),
    IRP_SHM_FIELD(S, name, "the module's name, NUL-terminated"),
    IRP_SHM_FIELD(S, next_due_ns, "irpd, at a release: when the process's next release is due (0: unknown)"),
    IRP_SHM_FIELD(S, wake_ns,
                  "process: its wait for a release ends by itself at this time; 0: only a FUTEX_WAKE ends it"),
    IRP_SHM_FIELD(S, release_at_ns,
                  "irpd: a release made ahead starts no sooner; 0: at once (and once claimed); INT64_MAX: taken back"),
    IRP_SHM_FIELD(S, started_ns, "process: when it started its last release"),
    IRP_SHM_FIELD(S, call, "this process's call of a shared function"),
};
IRP_SHM_DESCRIBES(indurop_process_slot, kSlot);

using A = indurop_call_area;
constexpr Field kCall[] = {
    IRP_SHM_FIELD(A, word, "futex: (tag << 2) | enum indurop_call_phase"),
    IRP_SHM_FIELD(A, function, "request: index in the function table"),
    IRP_SHM_FIELD(A, signature_hash, "request: FNV-1a 64 of the caller's typeid(R(A...)).name()"),
    IRP_SHM_FIELD(A, args_size, "request: packed argument bytes"),
    IRP_SHM_FIELD(A, result_size, "request: result bytes expected"),
    IRP_SHM_FIELD(A, status, "answer: enum indurop_call_status"),
    IRP_SHM_FIELD(A, reserved0, "zero"),
    IRP_SHM_FIELD(A, served_cycle, "answer: the owner executor's basic-period count when served"),
    IRP_SHM_FIELD(A, args, "the arguments, back to back in order, no padding"),
    IRP_SHM_FIELD(A, result, "the result's bytes; status THREW: the message, NUL-terminated"),
};
IRP_SHM_DESCRIBES(indurop_call_area, kCall);

using F = indurop_function_entry;
constexpr Field kFunction[] = {
    IRP_SHM_FIELD(F, name, "the exported name, NUL-terminated"),
    IRP_SHM_FIELD(F, signature, "typeid name of R(A...), cut if longer (the hash is of all of it)"),
    IRP_SHM_FIELD(F, owner, "the exporting module (empty if exported outside a lifecycle call)"),
    IRP_SHM_FIELD(F, signature_hash, "FNV-1a 64 of the whole typeid name"),
    IRP_SHM_FIELD(F, owner_period_ns, "0 when the owner has no period (sporadic)"),
    IRP_SHM_FIELD(F, owner_index, "the owner's index in module.xml; 4294967295: none"),
    IRP_SHM_FIELD(F, refusal, "0: callable from processes; else the enum indurop_call_status why not"),
    IRP_SHM_FIELD(F, args_size, "packed argument bytes"),
    IRP_SHM_FIELD(F, result_size, "result bytes"),
};
IRP_SHM_DESCRIBES(indurop_function_entry, kFunction);

constexpr Struct kStructs[] = {
    describe<H>("At offset 0", kHeader),
    describe<S>("From header_size on: slot_count of them, slot_size bytes apart, in module.xml order", kSlot),
    describe<A>("The call area inside each slot", kCall),
    describe<F>(
        "From function_offset on: function_count of them, sorted by name; written once before any process starts",
        kFunction),
};

constexpr Constant kConstants[] = {
    {"call_bytes", INDUROP_CALL_BYTES, "bytes of a call's arguments, and of its result, at most"},
    {"function_name_chars", INDUROP_FUNCTION_NAME_CHARS, "bytes of a function's name in the table, NUL included"},
    {"function_signature_chars", INDUROP_FUNCTION_SIGNATURE_CHARS, "bytes of a signature in the table"},
};

constexpr Constant kStates[] = {
    {"empty", INDUROP_PROCESS_EMPTY, "not started, or exited and not restarted"},
    {"starting", INDUROP_PROCESS_STARTING, "forked, initPeriodExe() not called yet"},
    {"ready", INDUROP_PROCESS_READY, "waiting in irp::waitPeriod()"},
    {"running", INDUROP_PROCESS_RUNNING, "released, working on its period"},
    {"exited", INDUROP_PROCESS_EXITED, "exited"},
};
constexpr Constant kPhases[] = {
    {"idle", INDUROP_CALL_IDLE, "no call"},
    {"pending", INDUROP_CALL_PENDING, "written by the process, not taken yet"},
    {"serving", INDUROP_CALL_SERVING, "irpd is calling the function"},
    {"answered", INDUROP_CALL_ANSWERED, "status (and result) written"},
};
constexpr Constant kStatuses[] = {
    {"ok", INDUROP_CALL_OK, "done"},
    {"unknown_function", INDUROP_CALL_UNKNOWN_FUNCTION, "no function of that name in the table"},
    {"signature_mismatch", INDUROP_CALL_SIGNATURE_MISMATCH, "the caller's R(A...) is not the export's"},
    {"too_large", INDUROP_CALL_TOO_LARGE, "arguments or result over call_bytes"},
    {"timeout", INDUROP_CALL_TIMEOUT, "no answer within the caller's timeout"},
    {"owner_disabled", INDUROP_CALL_OWNER_DISABLED, "the owner threw from run() and is disabled"},
    {"not_served", INDUROP_CALL_NOT_SERVED, "the owner is not a periodic thread module"},
    {"not_transferable", INDUROP_CALL_NOT_TRANSFERABLE,
     "the export takes or returns pointers, references or "
     "non-trivially-copyable types"},
    {"threw", INDUROP_CALL_THREW, "the function threw; result holds what()"},
    {"no_irpd", INDUROP_CALL_NO_IRPD, "not started by irpd, or its control segment unusable"},
    {"stopped", INDUROP_CALL_STOPPED, "irpd stopped serving calls (it is stopping)"},
    {"bad_request", INDUROP_CALL_BAD_REQUEST, "index or sizes do not match the export"},
    {"invalid", INDUROP_CALL_INVALID, "bad arguments to the call itself"},
};
constexpr Constant kCalls[] = {
    {"none", INDUROP_CALLS_NONE, "no table yet"},
    {"serving", INDUROP_CALLS_SERVING, "the table is published; requests are served"},
    {"stopped", INDUROP_CALLS_STOPPED, "the dispatcher stopped: nothing will be served any more"},
};

constexpr Enum kEnums[] = {
    {"indurop_process_state", "indurop_process_slot.state", kStates},
    {"indurop_call_phase", "the low two bits of indurop_call_area.word", kPhases},
    {"indurop_call_status", "indurop_call_area.status, indurop_function_entry.refusal", kStatuses},
    {"indurop_calls_state", "indurop_control_header.calls", kCalls},
};

}  // namespace

const Segment &controlSegment() {
    static constexpr Segment segment{
        "control",
        "/indurop.<instance>.ctl",
        "How irpd releases process modules and serves their calls of shared functions: [header][indurop_process_slot "
        "x slot_count][indurop_function_entry x function_count]. The handshakes are futexes on the slots' 32-bit "
        "words (<indurop/control.h>, docs/process-modules.md).",
        INDUROP_CONTROL_MAGIC,
        INDUROP_CONTROL_VERSION,
        TypeName<H>::value,
        kStructs,
        kConstants,
        kEnums};
    return segment;
}

}  // namespace irp::shm
