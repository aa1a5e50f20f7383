// variable_segment.cpp -- segment creation: sizes, the mutex attributes, the layout copy.
#include "variables/variable_segment.hpp"

#include "sdk/runtime.hpp"

#include <indurop/shared.h>

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <new>

namespace irp::variables {
namespace {

constexpr uint64_t roundUp(uint64_t v) { return (v + 63) & ~uint64_t{63}; }

} // namespace

std::string VariableSegment::shmName(const std::string &instance) { return "/indurop." + instance + ".vars"; }

Result<VariableSegment> VariableSegment::create(const std::string &instance, const Layout &layout) {
    const uint64_t locks_offset = roundUp(sizeof(indurop_segment_header));
    const uint64_t layout_offset = roundUp(locks_offset + uint64_t{layout.lock_count} * sizeof(indurop_var_lock));
    const uint64_t data_offset = roundUp(layout_offset + layout.text.size());
    const uint64_t total = data_offset + layout.data_size;

    const std::string name = shmName(instance);
    auto shm = osal::SharedMemory::createForInstance(name, total, instance, [](const osal::SharedMemory &old) -> int64_t {
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
    std::memcpy(base + layout_offset, layout.text.data(), layout.text.size());

    pthread_mutexattr_t attr;
    pthread_mutexattr_init(&attr);
    pthread_mutexattr_setpshared(&attr, PTHREAD_PROCESS_SHARED);
    pthread_mutexattr_setprotocol(&attr, PTHREAD_PRIO_INHERIT);
    pthread_mutexattr_setrobust(&attr, PTHREAD_MUTEX_ROBUST);
    auto *locks = reinterpret_cast<indurop_var_lock *>(base + locks_offset);
    for (uint32_t i = 0; i < layout.lock_count; ++i) {
        auto *lock = new (&locks[i]) indurop_var_lock{};
        if (int rc = pthread_mutex_init(&lock->mutex, &attr); rc != 0) {
            pthread_mutexattr_destroy(&attr);
            return Error{"shared variables: cannot create lock " + std::to_string(i) + ": " + std::strerror(rc)};
        }
    }
    pthread_mutexattr_destroy(&attr);

    VariableSegment segment;
    segment.shm_ = std::move(*shm);
    shared::adopt(segment.header());
    return segment;
}

VariableSegment::~VariableSegment() {
    if (shm_.data() && shared::segmentHeader() == header()) shared::adopt(nullptr);
}

} // namespace irp::variables
