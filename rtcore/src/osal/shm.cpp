// shm.cpp -- shm_open/mmap behind SharedMemory.
#include "osal/shm.hpp"

#include <signal.h>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <string>
#include <utility>

namespace irp::osal {

SharedMemory::SharedMemory(SharedMemory &&other) noexcept { *this = std::move(other); }

SharedMemory &SharedMemory::operator=(SharedMemory &&other) noexcept {
    if (this != &other) {
        reset();
        name_ = std::move(other.name_);
        data_ = std::exchange(other.data_, nullptr);
        size_ = std::exchange(other.size_, 0);
        owner_ = std::exchange(other.owner_, false);
    }
    return *this;
}

SharedMemory::~SharedMemory() { reset(); }

void SharedMemory::reset() noexcept {
    if (data_) munmap(data_, size_);
    if (owner_) shm_unlink(name_.c_str());
    data_ = nullptr;
    size_ = 0;
    owner_ = false;
}

Result<SharedMemory> SharedMemory::create(const std::string &name, std::size_t size, unsigned mode) {
    int fd = shm_open(name.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, mode);
    if (fd < 0) return Error{"shared memory " + name + ": " + std::strerror(errno)};
    fchmod(fd, mode);  // shm_open's mode is filtered by the umask
    if (ftruncate(fd, static_cast<off_t>(size)) != 0) {
        int e = errno;
        close(fd);
        shm_unlink(name.c_str());
        return Error{"shared memory " + name + ": cannot size to " + std::to_string(size) +
                     " bytes: " + std::strerror(e)};
    }
    void *p = mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    int e = errno;
    close(fd);
    if (p == MAP_FAILED) {
        shm_unlink(name.c_str());
        return Error{"shared memory " + name + ": mmap: " + std::strerror(e)};
    }
    SharedMemory shm;
    shm.name_ = name;
    shm.data_ = p;
    shm.size_ = size;
    shm.owner_ = true;
    return shm;
}

Result<SharedMemory> SharedMemory::open(const std::string &name, bool writable) {
    int fd = shm_open(name.c_str(), (writable ? O_RDWR : O_RDONLY) | O_CLOEXEC, 0);
    if (fd < 0) return Error{"shared memory " + name + ": " + std::strerror(errno)};
    struct stat st {};
    if (fstat(fd, &st) != 0 || st.st_size <= 0) {
        close(fd);
        return Error{"shared memory " + name + ": empty or unreadable"};
    }
    void *p = mmap(nullptr, static_cast<std::size_t>(st.st_size), writable ? PROT_READ | PROT_WRITE : PROT_READ,
                   MAP_SHARED, fd, 0);
    int e = errno;
    close(fd);
    if (p == MAP_FAILED) return Error{"shared memory " + name + ": mmap: " + std::strerror(e)};
    SharedMemory shm;
    shm.name_ = name;
    shm.data_ = p;
    shm.size_ = static_cast<std::size_t>(st.st_size);
    return shm;
}

bool SharedMemory::unlink(const std::string &name) { return shm_unlink(name.c_str()) == 0; }

namespace {

std::string commOf(const std::string &proc_dir) {
    std::ifstream in(proc_dir + "/comm");
    std::string comm;
    std::getline(in, comm);
    return comm;
}

// Whether `pid` is alive and runs this program (its command name is ours): after a crash its pid
// may have gone to another process, which must not keep the instance from starting again.  A
// process whose name cannot be read (hidepid) counts as this program.
bool runsThisProgram(int64_t pid) {
    if (kill(static_cast<pid_t>(pid), 0) != 0 && errno != EPERM) return false;
    const std::string theirs = commOf("/proc/" + std::to_string(pid));
    return theirs.empty() || theirs == commOf("/proc/self");
}

}  // namespace

Result<SharedMemory> SharedMemory::createForInstance(const std::string &name, std::size_t size,
                                                     const std::string &instance,
                                                     const std::function<int64_t(const SharedMemory &)> &owner_of) {
    auto shm = create(name, size, 0660);
    if (shm) return shm;
    if (auto old = open(name, false)) {
        const int64_t pid = owner_of(*old);
        if (pid > 0 && pid != getpid() && runsThisProgram(pid))
            return Error{"instance '" + instance + "' is in use by irpd pid " + std::to_string(pid) +
                         " (shared memory " + name + "); stop it or choose another --instance"};
    }
    unlink(name);
    return create(name, size, 0660);
}

}  // namespace irp::osal
