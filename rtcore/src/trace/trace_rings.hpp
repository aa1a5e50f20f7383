// trace_rings.hpp -- the trace rings of one irpd instance: every basic period the main dispatcher
// samples up to 64 scalar shared variables into rings in shared memory, which the agent reads to
// stream plots with every sample (docs/trace-and-stream.md; the layout is <indurop/trace.h>).
//
// Two sides, two threads:
//   - configure() / clear() / describe(), on the control thread: resolve paths against the
//     variables segment's layout, write the configuration that is not in force, ask for it;
//   - sample(), on the RT thread after each slot's work: take a pending configuration, write one
//     row (seq, due time, one double per channel), publish it.  No allocation, no lock, no syscall.
#pragma once

#include <indurop/result.hpp>
#include "osal/shm.hpp"

#include <indurop/trace.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace irp::variables {
class VariableSegment;
}

namespace irp::trace {

using json = nlohmann::ordered_json;

inline constexpr uint64_t kDefaultCapacity = 16384;  // 1.6 s at 100 us
inline constexpr uint64_t kMaxCapacity = uint64_t{1} << 20;
inline constexpr uint32_t kMaxChannels = INDUROP_TRACE_CHANNELS;
// Seqlock tries per channel and sample before the sampler takes the channel's previous value.
inline constexpr int kTornRetries = 16;

class TraceRings {
public:
    static std::string shmName(const std::string &instance);

    // Creates "/indurop.<instance>.trace" (mode 0660), every page touched and, where allowed,
    // locked, so that the RT thread never faults on it.  capacity: rows per ring, a power of two
    // from 2 to kMaxCapacity.  Refuses when a live irpd owns the name; replaces a dead one's.
    static Result<TraceRings> create(const std::string &instance, uint64_t capacity = kDefaultCapacity);

    TraceRings() = default;
    TraceRings(TraceRings &&) noexcept;
    TraceRings &operator=(TraceRings &&) noexcept;
    ~TraceRings();

    // ---- control thread --------------------------------------------------------------------
    // Traces `paths` (scalar leaves of the segment's layout, at most 64, no repeats) from the
    // sampler's next period on, replacing the current channels.  Refused, naming the path: an
    // unknown path, a struct or array (not a scalar), a path longer than the layout field.  The
    // answer is describe()'s.  The variables segment must outlive this configuration (configure
    // again, or clear(), before it is replaced).
    Result<json> configure(const std::vector<std::string> &paths, const variables::VariableSegment &vars);
    // No channels (rows keep coming, with seq and time only).
    Result<json> clear();
    // One reader's request (the agent's stream, the DDS bridge...): `paths` replace what `owner`
    // asked for before (empty: withdrawn), and the union of every owner's request is traced, the
    // channels traced already first and in their order, then the new ones.  Refused as configure()
    // refuses (a path twice in one request, a union over 64 channels naming who holds them); a
    // refusal leaves every owner's request and the channels in force as they were.  vars may be
    // null (a set without shared variables): then only an empty union is accepted.
    Result<json> configureFor(const std::string &owner, const std::vector<std::string> &paths,
                              const variables::VariableSegment *vars);
    // {"shm", "capacity", "basic_period_ns", "generation", "applied", "from_seq", "head",
    //  "torn_skips", "owners": {owner: [paths]}, "channels": [{"index", "path", "type"}]}: the last
    //  configuration asked for.
    json describe() const;
    // The sampling period, published in the header for readers (set it again after a swap).
    void setBasicPeriod(int64_t ns) noexcept;
    // Waits (sleeping) until the sampler put `generation` in force or a later one; false after timeout_ns.
    bool waitApplied(uint64_t generation, int64_t timeout_ns) const;
    uint64_t requestedGeneration() const;

    // ---- RT thread ---------------------------------------------------------------------------
    // One row for the basic period due at due_ns (CLOCK_MONOTONIC).  Call from one thread only.
    void sample(int64_t due_ns) noexcept;

    const std::string &name() const { return shm_.name(); }
    uint64_t capacity() const { return header_ ? header_->capacity : 0; }
    const indurop_trace_header *header() const { return header_; }

    struct Sampler;   // the RT side's private state
    struct Control;   // the control side's private state
    struct Resolved;  // one channel, resolved against a variables segment

private:
    Result<json> submit(std::vector<Resolved> channels);
    void apply(uint32_t index) noexcept;

    osal::SharedMemory shm_;
    indurop_trace_header *header_ = nullptr;
    std::unique_ptr<Sampler> sampler_;
    std::unique_ptr<Control> control_;
};

// The control protocol's `trace` command: {"channels": [paths], "owner": "agent"} sets that owner's
// request (an empty list withdraws it; owner defaults to "agent"), without "channels" it describes.  vars may be null (a set without shared variables: only an
// empty list is accepted).  Waits up to kApplyWaitNs for the sampler to take the new channels;
// "applied" in the answer says whether it did.
inline constexpr int64_t kApplyWaitNs = 200'000'000;
Result<json> handleTraceCommand(TraceRings &rings, const variables::VariableSegment *vars,
                                const nlohmann::json &request);

}  // namespace irp::trace
