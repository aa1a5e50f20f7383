// shm.hpp -- POSIX shared memory segments (shm_open + mmap) owned by irpd or mapped by readers.
#pragma once

#include "common/result.hpp"

#include <cstddef>
#include <string>

namespace irp::osal {

class SharedMemory {
public:
    SharedMemory() = default;
    SharedMemory(SharedMemory &&other) noexcept;
    SharedMemory &operator=(SharedMemory &&other) noexcept;
    SharedMemory(const SharedMemory &) = delete;
    SharedMemory &operator=(const SharedMemory &) = delete;
    ~SharedMemory();

    // Creates name ("/indurop.default.stats") with mode, zero-filled, mapped read-write.  Fails if
    // it exists; the owner unlinks it when destroyed.
    static Result<SharedMemory> create(const std::string &name, std::size_t size, unsigned mode);
    // Maps an existing segment; its whole size, read-only unless writable.
    static Result<SharedMemory> open(const std::string &name, bool writable);
    // Removes a name; true if it existed.
    static bool unlink(const std::string &name);

    void *data() const { return data_; }
    std::size_t size() const { return size_; }
    const std::string &name() const { return name_; }

private:
    void reset() noexcept;
    std::string name_;
    void *data_ = nullptr;
    std::size_t size_ = 0;
    bool owner_ = false;
};

} // namespace irp::osal
