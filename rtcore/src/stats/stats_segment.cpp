// stats_segment.cpp -- shm creation, stale-segment recovery and record set-up.
#include "stats/stats_segment.hpp"

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <new>

namespace irp::stats {

std::string StatsSegment::shmName(const std::string &instance) { return "/indurop." + instance + ".stats"; }

Result<StatsSegment> StatsSegment::create(const std::string &instance, std::size_t count) {
    const std::string name = shmName(instance);
    // A segment left over from an irpd that died is replaced; its header names the owner.
    auto shm = osal::SharedMemory::createForInstance(
        name, blockSize(count), instance, [](const osal::SharedMemory &old) -> int64_t {
            const auto *h = static_cast<const Header *>(old.data());
            return old.size() >= sizeof(Header) && h->magic == kMagic ? h->pid : 0;
        });
    if (!shm) return shm.error();
    StatsSegment segment;
    segment.shm_ = std::move(*shm);
    auto *h = new (segment.shm_.data()) Header();
    h->magic = kMagic;
    h->version = kVersion;
    h->header_size = sizeof(Header);
    h->record_size = sizeof(TimingRecord);
    h->record_count = static_cast<uint32_t>(count);
    h->pid = getpid();
    for (std::size_t i = 0; i < count; ++i) new (&records(h)[i]) TimingRecord();
    for (std::size_t i = 0; i < count; ++i) records(h)[i].kind = RecordKind::Unused;
    return segment;
}

TimingRecord &StatsSegment::describe(std::size_t i, RecordKind kind, const std::string &name,
                                     const std::string &executor, int64_t period_ns, int32_t priority,
                                     int64_t budget_ns) {
    TimingRecord &r = record(i);
    std::snprintf(r.name, sizeof r.name, "%s", name.c_str());
    std::snprintf(r.executor, sizeof r.executor, "%s", executor.c_str());
    r.kind = kind;
    r.priority = priority;
    r.period_ns = period_ns;
    r.budget_ns = budget_ns;
    resetFigures(r);
    return r;
}

void StatsSegment::release(std::size_t i) {
    TimingRecord &r = record(i);
    r.kind = RecordKind::Unused;
    r.name[0] = '\0';
    r.state.store(static_cast<uint32_t>(ModuleState::Stopped), std::memory_order_relaxed);
}

std::optional<std::size_t> StatsSegment::findUnused(std::size_t from) const {
    for (std::size_t i = from; i < recordCount(); ++i)
        if (record(i).kind == RecordKind::Unused) return i;
    return std::nullopt;
}

std::size_t StatsSegment::countUnused(std::size_t from) const {
    std::size_t n = 0;
    for (std::size_t i = from; i < recordCount(); ++i) n += record(i).kind == RecordKind::Unused;
    return n;
}

}  // namespace irp::stats
