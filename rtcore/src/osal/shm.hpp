// shm.hpp -- POSIX shared memory segments (shm_open + mmap) owned by irpd or mapped by readers.
#pragma once

#include <indurop/result.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
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
    // The same for one irpd instance's segment: if the name exists, owner_of(existing) tells which
    // irpd made it (0: unknown, not one of ours).  A live irpd other than this process refuses
    // ("instance 'x' is in use by irpd pid N"); a segment left by a dead one, or by a pid that
    // now runs another program, is replaced.
    static Result<SharedMemory> createForInstance(const std::string &name, std::size_t size,
                                                  const std::string &instance,
                                                  const std::function<int64_t(const SharedMemory &existing)> &owner_of);
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

}  // namespace irp::osal
