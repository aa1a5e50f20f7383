// variable_segment.cpp -- segment creation: sizes, the mutex attributes, the layout copy.
#include "variables/variable_segment.hpp"

#include "sdk/runtime.hpp"

#include <indurop/shared.h>

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <new>

namespace irp::variables {
namespace {

constexpr uint64_t roundUp(uint64_t v) { return (v + 63) & ~uint64_t{63}; }

}  // namespace

std::string VariableSegment::shmName(const std::string &instance) { return "/indurop." + instance + ".vars"; }

Result<VariableSegment> VariableSegment::create(const std::string &instance, const Layout &layout, Room room) {
    if (room.data_bytes > kMaxDataSize) return Error{"--var-headroom: at most 1 GiB"};
    const uint64_t data_capacity = roundUp(layout.data_size + room.data_bytes);
    const uint32_t lock_capacity =
        layout.lock_count + static_cast<uint32_t>(std::max<uint64_t>(256, room.data_bytes / 256));
    const uint64_t layout_capacity = roundUp(layout.text.size() + 2 * room.data_bytes);
    const uint64_t locks_offset = roundUp(sizeof(indurop_segment_header));
    const uint64_t layout_offset = roundUp(locks_offset + uint64_t{lock_capacity} * sizeof(indurop_var_lock));
    const uint64_t data_offset = layout_offset + 2 * layout_capacity;
    const uint64_t total = data_offset + data_capacity;

    const std::string name = shmName(instance);
    auto shm =
        osal::SharedMemory::createForInstance(name, total, instance, [](const osal::SharedMemory &old) -> int64_t {
            const auto *h = static_cast<const indurop_segment_header *>(old.data());
            return old.size() >= sizeof *h && h->magic == INDUROP_SEGMENT_MAGIC ? h->owner_pid : 0;
        });
    if (!shm) return shm.error();

    auto *base = static_cast<char *>(shm->data());
    auto *h = new (base) indurop_segment_header{};
    h->magic = INDUROP_SEGMENT_MAGIC;
    h->version = INDUROP_SEGMENT_VERSION;
    h->header_size = sizeof(indurop_segment_header);
    std::snprintf(h->layout_hash, sizeof h->layout_hash, "%s", layout.hash.c_str());
    h->total_size = total;
    h->locks_offset = locks_offset;
    h->lock_count = layout.lock_count;
    h->lock_size = sizeof(indurop_var_lock);
    h->layout_offset = layout_offset;
    h->layout_size = layout.text.size();
    h->data_offset = data_offset;
    h->data_size = layout.data_size;
    h->owner_pid = getpid();
    h->lock_capacity = lock_capacity;
    h->layout_capacity = layout_capacity;
    h->data_capacity = data_capacity;
    std::memcpy(base + layout_offset, layout.text.data(), layout.text.size());

    // Every lock of the capacity now: a lock of a variable added online is ready before its swap.
    pthread_mutexattr_t attr;
    pthread_mutexattr_init(&attr);
    pthread_mutexattr_setpshared(&attr, PTHREAD_PROCESS_SHARED);
    pthread_mutexattr_setprotocol(&attr, PTHREAD_PRIO_INHERIT);
    pthread_mutexattr_setrobust(&attr, PTHREAD_MUTEX_ROBUST);
    auto *locks = reinterpret_cast<indurop_var_lock *>(base + locks_offset);
    for (uint32_t i = 0; i < lock_capacity; ++i) {
        auto *lock = new (&locks[i]) indurop_var_lock{};
        if (int rc = pthread_mutex_init(&lock->mutex, &attr); rc != 0) {
            pthread_mutexattr_destroy(&attr);
            return Error{"shared variables: cannot create lock " + std::to_string(i) + ": " + std::strerror(rc)};
        }
    }
    pthread_mutexattr_destroy(&attr);

    VariableSegment segment;
    segment.shm_ = std::move(*shm);
    segment.layout_ = std::make_shared<const Layout>(layout);
    shared::adopt(segment.header());
    return segment;
}

std::string VariableSegment::fits(const Layout &next) const {
    const indurop_segment_header *h = header();
    auto why = [&](const std::string &what, uint64_t needs, uint64_t has) {
        return "the layout " + next.hash.substr(0, 12) + "… needs " + std::to_string(needs) + " " + what +
               "; the running "
               "segment has room for " +
               std::to_string(has) +
               " (made with irpd's --var-headroom, default 1M, which "
               "also sizes the locks and the layout text): restart irpd with a larger --var-headroom, or activate "
               "with a restart (a new segment sized for the set)";
    };
    if (next.data_size > h->data_capacity) return why("bytes of data", next.data_size, h->data_capacity);
    if (next.lock_count > h->lock_capacity) return why("locks", next.lock_count, h->lock_capacity);
    if (next.text.size() > h->layout_capacity) return why("bytes of layout text", next.text.size(), h->layout_capacity);
    return "";
}

Status VariableSegment::publish(const Layout &next, const std::vector<std::string> &fresh) {
    if (std::string why = fits(next); !why.empty()) return Error{why};
    auto *base = static_cast<char *>(shm_.data());
    auto *h = reinterpret_cast<indurop_segment_header *>(base);
    for (const std::string &path : fresh)
        if (const layouts::Variable *v = next.model.self.find(path))
            std::memset(base + h->data_offset + v->offset, 0, v->size);
    const uint64_t first_half = roundUp(h->locks_offset + uint64_t{h->lock_capacity} * sizeof(indurop_var_lock));
    const uint64_t idle = h->layout_offset == first_half ? first_half + h->layout_capacity : first_half;
    std::memcpy(base + idle, next.text.data(), next.text.size());

    std::atomic_ref<uint32_t> seq(h->layout_seq);
    const uint32_t s = seq.load(std::memory_order_relaxed);
    seq.store(s + 1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    std::snprintf(h->layout_hash, sizeof h->layout_hash, "%s", next.hash.c_str());
    h->layout_offset = idle;
    h->layout_size = next.text.size();
    h->lock_count = next.lock_count;
    h->data_size = next.data_size;
    seq.store(s + 2, std::memory_order_release);
    auto published = std::make_shared<const Layout>(next);
    std::lock_guard lock(*layout_mutex_);
    layout_ = std::move(published);
    return Ok{};
}

VariableSegment::~VariableSegment() {
    if (shm_.data() && shared::segmentHeader() == header()) shared::adopt(nullptr);
}

}  // namespace irp::variables
