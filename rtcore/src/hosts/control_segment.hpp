// control_segment.hpp -- the control segment of one irpd instance: a slot per process module,
// through which the dispatcher releases processes and learns when they are done, and the table
// of shared functions those processes may call (see <indurop/control.h> for both protocols).
#pragma once

#include "common/result.hpp"
#include "osal/shm.hpp"

#include <indurop/control.h>

#include <string>

namespace irp::hosts {

class ControlSegment {
public:
    static std::string shmName(const std::string &instance);  // "/indurop.<instance>.ctl"

    // slot_count slots, all EMPTY, and room for function_count function entries (all zero; the
    // table is filled by dispatch::CallServer::publish).  Refuses when a live irpd owns the name.
    static Result<ControlSegment> create(const std::string &instance, uint32_t slot_count, uint32_t function_count = 0);

    indurop_control_header *header() const { return static_cast<indurop_control_header *>(shm_.data()); }
    indurop_process_slot &slot(uint32_t i) const {
        return reinterpret_cast<indurop_process_slot *>(static_cast<char *>(shm_.data()) + header()->header_size)[i];
    }
    uint32_t slotCount() const { return header()->slot_count; }
    indurop_function_entry &function(uint32_t i) const {
        return reinterpret_cast<indurop_function_entry *>(static_cast<char *>(shm_.data()) + header()->function_offset)[i];
    }
    uint32_t functionCount() const { return header()->function_count; }
    const std::string &name() const { return shm_.name(); }

private:
    osal::SharedMemory shm_;
};

// Futex helpers on the slots' 32-bit words (process-shared: no FUTEX_PRIVATE_FLAG).
namespace futex {
// Wakes every waiter on word.
void wakeAll(uint32_t *word) noexcept;
// Waits while *word == expected, at most timeout_ns (0: no limit).  Returns false on timeout.
bool waitWhileEqual(uint32_t *word, uint32_t expected, int64_t timeout_ns) noexcept;
} // namespace futex

} // namespace irp::hosts
