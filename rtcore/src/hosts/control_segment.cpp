// control_segment.cpp -- control segment creation and the futex calls.
#include "hosts/control_segment.hpp"

#include <linux/futex.h>
#include <signal.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <ctime>
#include <new>

namespace irp::hosts {

std::string ControlSegment::shmName(const std::string &instance) { return "/indurop." + instance + ".ctl"; }

static_assert(sizeof(indurop_control_header) % 8 == 0 && sizeof(indurop_process_slot) % 8 == 0 &&
                  sizeof(indurop_function_entry) % 8 == 0,
              "control segment parts keep 8-byte alignment for the 64-bit words that follow them");
static_assert(offsetof(indurop_process_slot, call) % 8 == 0 && offsetof(indurop_call_area, args) % 8 == 0,
              "the call area's 64-bit words are naturally aligned");

Result<ControlSegment> ControlSegment::create(const std::string &instance, uint32_t slot_count,
                                              uint32_t function_count) {
    const std::string name = shmName(instance);
    const std::size_t functions_at =
        sizeof(indurop_control_header) + std::size_t{slot_count} * sizeof(indurop_process_slot);
    const std::size_t size = functions_at + std::size_t{function_count} * sizeof(indurop_function_entry);
    auto shm =
        osal::SharedMemory::createForInstance(name, size, instance, [](const osal::SharedMemory &old) -> int64_t {
            const auto *h = static_cast<const indurop_control_header *>(old.data());
            return old.size() >= sizeof *h && h->magic == INDUROP_CONTROL_MAGIC ? h->owner_pid : 0;
        });
    if (!shm) return shm.error();
    ControlSegment segment;
    segment.shm_ = std::move(*shm);
    auto *h = new (segment.shm_.data()) indurop_control_header{};
    h->magic = INDUROP_CONTROL_MAGIC;
    h->version = INDUROP_CONTROL_VERSION;
    h->header_size = sizeof(indurop_control_header);
    h->slot_size = sizeof(indurop_process_slot);
    h->slot_count = slot_count;
    h->owner_pid = getpid();
    h->function_offset = functions_at;
    h->function_count = function_count;
    h->function_size = sizeof(indurop_function_entry);
    h->calls = INDUROP_CALLS_NONE;
    h->call_bytes = INDUROP_CALL_BYTES;
    for (uint32_t i = 0; i < slot_count; ++i) new (&segment.slot(i)) indurop_process_slot{};
    for (uint32_t i = 0; i < function_count; ++i) new (&segment.function(i)) indurop_function_entry{};
    return segment;
}

}  // namespace irp::hosts
