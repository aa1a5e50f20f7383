// alarm_segment.hpp -- the alarm segment of one irpd instance ("/indurop.<instance>.alarms",
// laid out by <indurop/alarms.h>): irpd creates it, gives sources to the modules of the running
// set, and reads the sources for the `alarms` command; libindurop's irp::raiseAlarm and
// irp::clearAlarm write it (rtcore/sdk/alarms.cpp), and the agent reads the ring (docs/alarms.md).
//
// Two sides, two threads, and never the RT one here:
//   - claim() / declare() / release(), on irpd's main thread (the reloader, at a set's start and
//     at every swap): a source's name, generation and declared bitmap;
//   - view(), on the control thread: a source's counters and active ids, each read atomically.
#pragma once

#include <indurop/result.hpp>
#include "osal/shm.hpp"
#include "protocol/limits.hpp"

#include <indurop/alarms.h>

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace irp::alarms {

// The ids of one source, bit id of word id / 64 (as the segment's bitmaps).
using Bitmap = std::array<uint64_t, INDUROP_ALARM_BITMAP_WORDS>;

inline void setBit(Bitmap &bits, uint32_t id) { bits[id / 64] |= uint64_t{1} << (id % 64); }

inline constexpr uint64_t kDefaultCapacity = 4096;  // records: four seconds of every source at its rate limit
inline constexpr uint64_t kMaxCapacity = uint64_t{1} << 20;
inline constexpr uint32_t kIrpdSource = 0;  // irpd's own; modules have 1 ..

// What the control thread reads of one source.
struct SourceView {
    uint32_t source = 0;
    std::string name;  // "" = unused
    uint64_t generation = 0;
    std::vector<uint32_t> active;  // ids, ascending
    uint64_t recorded = 0, rate_dropped = 0, undeclared = 0, bad_ids = 0, truncated = 0, collided = 0;
};

class AlarmSegment {
public:
    static std::string shmName(const std::string &instance);

    // Creates "/indurop.<instance>.alarms" (mode 0660), every page touched and, where allowed,
    // locked, with `source_max` sources (source 0 claimed for irpd) and a ring of `capacity`
    // records (a power of two from 2 to kMaxCapacity).  Refuses when a live irpd owns the name;
    // replaces a dead one's.
    static Result<AlarmSegment> create(const std::string &instance, uint32_t source_max,
                                       uint64_t capacity = kDefaultCapacity,
                                       uint32_t rate_limit = static_cast<uint32_t>(protocol::kAlarmRateLimit));

    AlarmSegment() = default;
    AlarmSegment(AlarmSegment &&other) noexcept;
    AlarmSegment &operator=(AlarmSegment &&other) noexcept;
    ~AlarmSegment();  // this process's libindurop lets go of it first, if it was adopted

    // This process's libindurop writes its modules' alarms here (irpd: thread modules).
    void adopt();

    // ---- main thread -------------------------------------------------------------------------
    // Gives `source` to module `name`: a new generation, the declared ids, every other field zero.
    void claim(uint32_t source, std::string_view name, const Bitmap &declared);
    // The declared ids of a source in use: exactly `declared`, or `declared` added to its own.
    void declare(uint32_t source, const Bitmap &declared, bool add = false);
    // The source is unused again: all zero.
    void release(uint32_t source);
    bool inUse(uint32_t source) const;

    // ---- any thread ----------------------------------------------------------------------------
    SourceView view(uint32_t source) const;
    uint32_t sourceMax() const { return header_ ? header_->source_max : 0; }
    uint32_t rateLimit() const { return header_ ? header_->rate_limit : 0; }
    const std::string &name() const { return shm_.name(); }
    indurop_alarm_header *header() const { return header_; }
    indurop_alarm_source &source(uint32_t i) const;

private:
    osal::SharedMemory shm_;
    indurop_alarm_header *header_ = nullptr;
    uint64_t next_generation_ = 1;
    bool adopted_ = false;
};

}  // namespace irp::alarms
