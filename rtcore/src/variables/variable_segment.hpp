// variable_segment.hpp -- the shared-variable segment of one irpd instance, created from a layout.
//
// "/indurop.<instance>.vars", mode 0660: header, lock table (robust, process-shared,
// priority-inheritance mutexes), the layout text, then the zero-filled data area (see
// <indurop/segment.h>).  Creating it also makes it this process's segment in libindurop, so the
// thread modules loaded afterwards see it.
#pragma once

#include "common/result.hpp"
#include "osal/shm.hpp"
#include "variables/layout.hpp"

#include <indurop/segment.h>

#include <string>

namespace irp::variables {

class VariableSegment {
public:
    static std::string shmName(const std::string &instance);

    // Refuses when a live irpd owns the name; replaces a segment left by a dead one.
    static Result<VariableSegment> create(const std::string &instance, const Layout &layout);

    VariableSegment() = default;
    VariableSegment(VariableSegment &&) noexcept = default;
    VariableSegment &operator=(VariableSegment &&) noexcept = default;
    ~VariableSegment();

    const indurop_segment_header *header() const { return static_cast<const indurop_segment_header *>(shm_.data()); }
    const std::string &name() const { return shm_.name(); }
    const char *hash() const { return header()->layout_hash; }

private:
    osal::SharedMemory shm_;
};

} // namespace irp::variables
