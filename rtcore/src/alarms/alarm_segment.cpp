// alarm_segment.cpp -- the alarm segment: created, its sources given and taken back, read.
#include "alarms/alarm_segment.hpp"

#include "sdk/runtime.hpp"

#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <bit>
#include <cstring>
#include <new>
#include <utility>

namespace irp::alarms {
namespace {

constexpr uint64_t roundUp(uint64_t v) { return (v + 63) & ~uint64_t{63}; }

// The fields writers change are atomic for everyone (libindurop writes them with atomic_ref too).
template <class T>
T load(const T &field) noexcept {
    return std::atomic_ref<T>(const_cast<T &>(field)).load(std::memory_order_acquire);
}
template <class T>
void store(T &field, T value) noexcept {
    std::atomic_ref<T>(field).store(value, std::memory_order_release);
}

// Everything of a source but its name and declared ids to zero, the generation first (unused).
void clearState(indurop_alarm_source &s) noexcept {
    store(s.generation, uint64_t{0});
    for (uint64_t &w : s.active) store(w, uint64_t{0});
    for (uint64_t *counter :
         {&s.recorded, &s.rate_dropped, &s.undeclared, &s.bad_ids, &s.truncated, &s.collided, &s.window_count})
        store(*counter, uint64_t{0});
    store(s.window_ns, int64_t{0});
}

}  // namespace

std::string AlarmSegment::shmName(const std::string &instance) { return "/indurop." + instance + ".alarms"; }

AlarmSegment::AlarmSegment(AlarmSegment &&other) noexcept { *this = std::move(other); }

AlarmSegment &AlarmSegment::operator=(AlarmSegment &&other) noexcept {
    if (this != &other) {
        if (adopted_) runtime::adoptAlarms(nullptr);
        shm_ = std::move(other.shm_);
        header_ = std::exchange(other.header_, nullptr);
        next_generation_ = other.next_generation_;
        adopted_ = std::exchange(other.adopted_, false);
    }
    return *this;
}

AlarmSegment::~AlarmSegment() {
    if (adopted_) runtime::adoptAlarms(nullptr);
}

Result<AlarmSegment> AlarmSegment::create(const std::string &instance, uint32_t source_max, uint64_t capacity,
                                          uint32_t rate_limit) {
    if (capacity < 2 || capacity > kMaxCapacity || !std::has_single_bit(capacity))
        return Error{"alarm segment: capacity " + std::to_string(capacity) + " is not a power of two from 2 to " +
                     std::to_string(kMaxCapacity)};
    if (source_max < 1) return Error{"alarm segment: no room for a source"};
    const uint64_t sources_offset = roundUp(sizeof(indurop_alarm_header));
    const uint64_t records_offset = roundUp(sources_offset + uint64_t{source_max} * sizeof(indurop_alarm_source));
    const uint64_t total = records_offset + capacity * sizeof(indurop_alarm_record);

    auto shm = osal::SharedMemory::createForInstance(
        shmName(instance), total, instance, [](const osal::SharedMemory &old) -> int64_t {
            const auto *h = static_cast<const indurop_alarm_header *>(old.data());
            return old.size() >= sizeof *h && h->magic == INDUROP_ALARMS_MAGIC ? h->owner_pid : 0;
        });
    if (!shm) return shm.error();
    // Touch every page now (and lock them where the limit allows): the RT thread must not fault.
    std::memset(shm->data(), 0, total);
    mlock(shm->data(), total);

    auto *h = new (shm->data()) indurop_alarm_header{};
    h->version = INDUROP_ALARMS_VERSION;
    h->header_size = sizeof(indurop_alarm_header);
    h->total_size = total;
    h->capacity = capacity;
    h->record_size = sizeof(indurop_alarm_record);
    h->source_size = sizeof(indurop_alarm_source);
    h->source_max = source_max;
    h->rate_limit = rate_limit;
    h->sources_offset = sources_offset;
    h->records_offset = records_offset;
    h->owner_pid = getpid();
    AlarmSegment segment;
    segment.shm_ = std::move(*shm);
    segment.header_ = h;
    segment.claim(kIrpdSource, "irpd", Bitmap{});
    store(h->magic, uint64_t{INDUROP_ALARMS_MAGIC});  // last: a reader seeing the magic sees the rest
    return segment;
}

void AlarmSegment::adopt() {
    runtime::adoptAlarms(header_);
    adopted_ = header_ != nullptr;
}

indurop_alarm_source &AlarmSegment::source(uint32_t i) const {
    return reinterpret_cast<indurop_alarm_source *>(reinterpret_cast<char *>(header_) + header_->sources_offset)[i];
}

// The name first, then the generation with release: a reader that loads the generation (acquire),
// the name and the generation again sees a name that goes with it.
void AlarmSegment::claim(uint32_t i, std::string_view name, const Bitmap &declared) {
    indurop_alarm_source &s = source(i);
    clearState(s);
    declare(i, declared);
    std::memset(s.name, 0, sizeof s.name);
    std::memcpy(s.name, name.data(), std::min(name.size(), sizeof s.name - 1));
    store(s.generation, next_generation_++);
}

void AlarmSegment::declare(uint32_t i, const Bitmap &declared, bool add) {
    indurop_alarm_source &s = source(i);
    for (std::size_t w = 0; w < declared.size(); ++w)
        if (add)
            std::atomic_ref<uint64_t>(s.declared[w]).fetch_or(declared[w], std::memory_order_acq_rel);
        else
            store(s.declared[w], declared[w]);
}

void AlarmSegment::release(uint32_t i) {
    clearState(source(i));
    declare(i, Bitmap{});
    std::memset(source(i).name, 0, sizeof source(i).name);
}

bool AlarmSegment::inUse(uint32_t i) const { return i < sourceMax() && load(source(i).generation) != 0; }

SourceView AlarmSegment::view(uint32_t i) const {
    const indurop_alarm_source &s = source(i);
    SourceView v;
    v.source = i;
    v.generation = load(s.generation);
    v.name.assign(s.name, strnlen(s.name, sizeof s.name));
    for (uint32_t w = 0; w < INDUROP_ALARM_BITMAP_WORDS; ++w)
        for (uint64_t bits = load(s.active[w]); bits; bits &= bits - 1)
            v.active.push_back(w * 64 + static_cast<uint32_t>(std::countr_zero(bits)));
    v.recorded = load(s.recorded);
    v.rate_dropped = load(s.rate_dropped);
    v.undeclared = load(s.undeclared);
    v.bad_ids = load(s.bad_ids);
    v.truncated = load(s.truncated);
    v.collided = load(s.collided);
    return v;
}

}  // namespace irp::alarms
