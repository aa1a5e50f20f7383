// variable_segment.hpp -- the shared-variable segment of one irpd instance, created from a layout.
//
// "/indurop.<instance>.vars", mode 0660: header, lock table (robust, process-shared,
// priority-inheritance mutexes), the layout text, then the zero-filled data area (see
// <indurop/segment.h>).  Creating it also makes it this process's segment in libindurop, so the
// thread modules loaded afterwards see it.
//
// It is made with room to grow (Room): an online change publishes a layout that adds variables
// (docs/shared-variables.md, "Layouts that evolve") without remapping anything.
#pragma once

#include <indurop/result.hpp>
#include "osal/shm.hpp"
#include "variables/layout.hpp"

#include <indurop/segment.h>

#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace irp::variables {

// The room beyond the first layout: bytes of data and locks for variables added online, and the
// text area for their layouts.  irpd's --var-headroom sets data_bytes (docs/shared-variables.md).
struct Room {
    static constexpr uint64_t kDefaultDataBytes = 1u << 20;  // 1 MiB
    uint64_t data_bytes = kDefaultDataBytes;
};

class VariableSegment {
public:
    static std::string shmName(const std::string &instance);

    // Refuses when a live irpd owns the name; replaces a segment left by a dead one.
    static Result<VariableSegment> create(const std::string &instance, const Layout &layout, Room room = {});

    // Whether `next` fits the room: "" or the limit it exceeds and the option that raises it.
    std::string fits(const Layout &next) const;
    // Publishes `next` as the segment's layout (the control thread and the agent see it at once):
    // zeroes the bytes of `fresh` variables (new or moved: not used by the running layout), writes
    // the text into the idle half, then switches the header's layout fields under layout_seq.
    // Checks fits() first; never touches the bytes of variables that stay.
    Status publish(const Layout &next, const std::vector<std::string> &fresh = {});
    // The layout published last (what was given to create() or publish()).  Any thread: the
    // control thread's check reads it while the main thread may publish.
    std::shared_ptr<const Layout> layout() const {
        std::lock_guard lock(*layout_mutex_);
        return layout_;
    }

    VariableSegment() = default;
    VariableSegment(VariableSegment &&) noexcept = default;
    VariableSegment &operator=(VariableSegment &&) noexcept = default;
    ~VariableSegment();

    const indurop_segment_header *header() const { return static_cast<const indurop_segment_header *>(shm_.data()); }
    // The data area (the variables' offsets are relative to it).
    char *data() const { return static_cast<char *>(shm_.data()) + header()->data_offset; }
    const std::string &name() const { return shm_.name(); }
    const char *hash() const { return header()->layout_hash; }

private:
    osal::SharedMemory shm_;
    std::unique_ptr<std::mutex> layout_mutex_ = std::make_unique<std::mutex>();  // movable segment
    std::shared_ptr<const Layout> layout_;
};

}  // namespace irp::variables
