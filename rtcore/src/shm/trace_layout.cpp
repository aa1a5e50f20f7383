// trace_layout.cpp -- the trace rings ("/indurop.<instance>.trace", <indurop/trace.h>) described
// field by field for --print-shm-layout.
#include "shm/describe.hpp"

#include <indurop/trace.h>

namespace irp::shm {

IRP_SHM_TYPE_NAME(indurop_trace_header, "indurop_trace_header");
IRP_SHM_TYPE_NAME(indurop_trace_config, "indurop_trace_config");
IRP_SHM_TYPE_NAME(indurop_trace_channel, "indurop_trace_channel");

namespace {

using H = indurop_trace_header;
constexpr Field kHeader[] = {
    IRP_SHM_FIELD(H, magic, "the bytes IRPTRAC1; stored last at creation"),
    IRP_SHM_FIELD(H, version, "the segment's format version"),
    IRP_SHM_FIELD(H, header_size, "bytes of this header"),
    IRP_SHM_FIELD(H, total_size, "bytes of the segment"),
    IRP_SHM_FIELD(H, capacity, "rows per ring, a power of two"),
    IRP_SHM_FIELD(H, channel_max, "channels per configuration"),
    IRP_SHM_FIELD(H, channel_size, "bytes of one indurop_trace_channel"),
    IRP_SHM_FIELD(H, config_size, "bytes of one indurop_trace_config"),
    IRP_SHM_FIELD(H, reserved0, "zero"),
    IRP_SHM_FIELD(H, configs_offset, "the two configurations, indurop_trace_config[2]"),
    IRP_SHM_FIELD(H, seq_offset, "u64[capacity]: the seq of the row at each index"),
    IRP_SHM_FIELD(H, time_offset, "i64[capacity]: CLOCK_MONOTONIC due time of the row's basic period, ns"),
    IRP_SHM_FIELD(H, values_offset,
                  "f64[channel_max][capacity], channel-major: column c of row index i at "
                  "values_offset + 8 x (c x capacity + i)"),
    IRP_SHM_FIELD(H, owner_pid, "the irpd that created the segment"),
    IRP_SHM_FIELD(H, basic_period_ns, "the sampling period (atomic; irpd sets it again when a swap changes it)"),
    IRP_SHM_FIELD(H, reserved1, "zero"),
    IRP_SHM_FIELD(H, head, "seq of the newest complete row, 0 before the first; release-stored by the sampler"),
    IRP_SHM_FIELD(H, config_generation, "generation of the configuration in force (sampler)"),
    IRP_SHM_FIELD(H, config_seq, "the first seq sampled with it (sampler)"),
    IRP_SHM_FIELD(H, active_config, "0 or 1: which configuration is in force (sampler)"),
    IRP_SHM_FIELD(H, reserved2, "zero"),
    IRP_SHM_FIELD(H, torn_skips, "channel samples that took the previous value: a writer stayed inside its seqlock"),
    IRP_SHM_FIELD(H, reserved3, "zero; the sampler's fields end here, on a cache line of their own"),
    IRP_SHM_FIELD(H, pending_config, "control thread to sampler: 0, or 1 + index of the configuration asked for"),
    IRP_SHM_FIELD(H, reserved4, "zero"),
    IRP_SHM_FIELD(H, reserved5, "zero; the control thread's cache line"),
};
IRP_SHM_DESCRIBES(indurop_trace_header, kHeader);

using C = indurop_trace_config;
constexpr Field kConfig[] = {
    IRP_SHM_FIELD(C, generation,
                  "> 0, increasing from one configuration to the next; 0 while the control thread "
                  "rewrites it (read again)"),
    IRP_SHM_FIELD(C, first_seq, "the first row sampled with it; no_seq while not (yet) in force"),
    IRP_SHM_FIELD(C, channel_count, "channels in use, 0 to channel_max"),
    IRP_SHM_FIELD(C, reserved0, "zero"),
    IRP_SHM_FIELD(C, reserved, "zero"),
    IRP_SHM_FIELD(C, channels, "column c of a row sampled with this configuration is channels[c]"),
};
IRP_SHM_DESCRIBES(indurop_trace_config, kConfig);

using Ch = indurop_trace_channel;
constexpr Field kChannel[] = {
    IRP_SHM_FIELD(Ch, path, "the variable's path (\"knu.Robot.joints[0].x\"), NUL-terminated"),
    IRP_SHM_FIELD(Ch, offset, "bytes into the variables segment's data area"),
    IRP_SHM_FIELD(Ch, type, "how the variable is stored (enum indurop_trace_type); the rings hold it as f64"),
    IRP_SHM_FIELD(Ch, lock, "the lock (seqlock) index of its top-level variable"),
    IRP_SHM_FIELD(Ch, size, "bytes of the variable: 1, 2, 4 or 8"),
    IRP_SHM_FIELD(Ch, reserved, "zero"),
};
IRP_SHM_DESCRIBES(indurop_trace_channel, kChannel);

constexpr Struct kStructs[] = {
    describe<H>("At offset 0; the cache line from head on is written by the sampler only, the one from "
                "pending_config on by the control thread",
                kHeader),
    describe<C>("Two of them at configs_offset, config_size bytes apart; read like a seqlock on generation", kConfig),
    describe<Ch>("A traced scalar variable", kChannel),
};

constexpr Constant kConstants[] = {
    {"channels", INDUROP_TRACE_CHANNELS, "channels per configuration"},
    {"path_chars", INDUROP_TRACE_PATH_CHARS, "bytes of a channel's path, NUL included"},
    {"no_seq", INDUROP_TRACE_NO_SEQ, "first_seq of a configuration not (yet) in force"},
};

// Each value's name is the type as glbc's layout.json spells it.
constexpr Constant kTypes[] = {
    {"none", INDUROP_TRACE_NONE, "unused channel"},        {"float", INDUROP_TRACE_FLOAT32, "32-bit float"},
    {"double", INDUROP_TRACE_FLOAT64, "64-bit float"},     {"int8_t", INDUROP_TRACE_INT8, "signed 8-bit"},
    {"int16_t", INDUROP_TRACE_INT16, "signed 16-bit"},     {"int32_t", INDUROP_TRACE_INT32, "signed 32-bit"},
    {"int64_t", INDUROP_TRACE_INT64, "signed 64-bit"},     {"uint8_t", INDUROP_TRACE_UINT8, "unsigned 8-bit"},
    {"uint16_t", INDUROP_TRACE_UINT16, "unsigned 16-bit"}, {"uint32_t", INDUROP_TRACE_UINT32, "unsigned 32-bit"},
    {"uint64_t", INDUROP_TRACE_UINT64, "unsigned 64-bit"}, {"bool", INDUROP_TRACE_BOOL, "0 or 1"},
};

constexpr Enum kEnums[] = {
    {"indurop_trace_type", "indurop_trace_channel.type, named as layout.json names the type", kTypes},
};

}  // namespace

const Segment &traceSegment() {
    static constexpr Segment segment{
        "trace",
        "/indurop.<instance>.trace",
        "Rings of one row per basic period of the main dispatcher: [header][indurop_trace_config x 2][u64 "
        "seq[capacity]]"
        "[i64 t_ns[capacity]][f64 values[channel_max][capacity]], each part on a 64-byte boundary. Row seq sits at "
        "index seq % capacity of every ring; single writer (the RT sampler), readers never wait "
        "(docs/trace-and-stream.md).",
        INDUROP_TRACE_MAGIC,
        INDUROP_TRACE_VERSION,
        TypeName<H>::value,
        kStructs,
        kConstants,
        kEnums};
    return segment;
}

}  // namespace irp::shm
