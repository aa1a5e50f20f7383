// control_segment.hpp -- the control segment of one irpd instance: a slot per process module,
// through which the dispatcher releases processes and learns when they are done, and the table
// of shared functions those processes may call (see <indurop/control.h> for both protocols).
#pragma once

#include <indurop/result.hpp>
#include "osal/shm.hpp"
#include "sdk/sync.hpp"

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
        return reinterpret_cast<indurop_function_entry *>(static_cast<char *>(shm_.data()) +
                                                          header()->function_offset)[i];
    }
    uint32_t functionCount() const { return header()->function_count; }
    const std::string &name() const { return shm_.name(); }

private:
    osal::SharedMemory shm_;
};

// The futex calls on the slots' words: irp::futex (sdk/sync.hpp), shared with libindurop.
}  // namespace irp::hosts
