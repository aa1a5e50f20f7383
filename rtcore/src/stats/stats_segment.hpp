// stats_segment.hpp -- creates and owns the shared-memory stats block of one irpd instance.
#pragma once

#include <indurop/result.hpp>
#include "osal/shm.hpp"
#include "stats/stats_block.hpp"

#include <optional>
#include <string>

namespace irp::stats {

class StatsSegment {
public:
    // "/indurop.<instance>.stats"
    static std::string shmName(const std::string &instance);

    // Creates the segment for `records` records (mode 0660).  A segment left by a dead irpd is
    // replaced; one owned by a live process is refused.
    static Result<StatsSegment> create(const std::string &instance, std::size_t records);

    Header *header() const { return static_cast<Header *>(shm_.data()); }
    TimingRecord &record(std::size_t i) const { return records(header())[i]; }
    std::size_t recordCount() const { return header()->record_count; }
    const std::string &name() const { return shm_.name(); }

    // Sets name, executor, kind, period and clears the figures of record i.
    TimingRecord &describe(std::size_t i, RecordKind kind, const std::string &name, const std::string &executor,
                           int64_t period_ns, int32_t priority, int64_t budget_ns);

    // Marks record i unused (a module that a hot reload removed); readers skip it.
    void release(std::size_t i);
    // The first unused record at or after `from`.
    std::optional<std::size_t> findUnused(std::size_t from) const;
    // How many records at or after `from` are unused.
    std::size_t countUnused(std::size_t from) const;

private:
    osal::SharedMemory shm_;
};

}  // namespace irp::stats
