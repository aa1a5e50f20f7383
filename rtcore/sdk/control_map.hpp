// control_map.hpp -- libindurop's one mapping of irpd's control segment (INDUROP_CTL) and of this
// process's slot in it (INDUROP_SLOT), shared by the period handshake (process.cpp) and by calls
// of shared functions (calls.cpp).  Not installed.
#pragma once

#include <indurop/control.h>

#include "sync.hpp"

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <ctime>
#include <string>

namespace irp::sdk {

struct ControlMap {
    indurop_control_header *header = nullptr;
    std::size_t size = 0;
    indurop_process_slot *slot = nullptr;
};

// Maps the segment at the first call and returns the same mapping afterwards (the mapping stays
// for the life of the process).  On failure: null, and `why` says it without a prefix, e.g. "not
// started by irpd (INDUROP_CTL is not set)"; the next call tries again.  The first call allocates
// and makes syscalls; later ones are one atomic load.
const ControlMap *mapControl(std::string &why);

// The slot's words are shared with irpd: every access is atomic.
template <class T>
std::atomic_ref<T> atomic(T &word) noexcept {
    return std::atomic_ref<T>(word);
}

using irp::monotonicNs;  // sync.hpp

}  // namespace irp::sdk
