// shared.cpp -- libindurop's side of shared variables: where the segment is mapped in this
// process, the variables' locks, and attaching to a segment by name (process modules, tools).
#include <indurop/segment.h>
#include <indurop/shared.h>

#include "runtime.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <string>

extern "C" {
char *indurop_shared_data = nullptr;
indurop_var_lock *indurop_shared_locks = nullptr;
}

namespace irp::shared {
namespace {

const indurop_segment_header *g_header = nullptr;
void *g_mapping = nullptr;  // our own mmap (not irpd's adopted one)
std::size_t g_mapping_size = 0;
std::atomic<uint64_t> g_repaired{0};

// A function-local static: the attach below runs from a load-time constructor, possibly before
// this file's namespace-scope objects are constructed.
std::string &attachErrorText() {
    static std::string text;
    return text;
}

void publish(const indurop_segment_header *h) {
    g_header = h;
    auto *base = reinterpret_cast<char *>(const_cast<indurop_segment_header *>(h));
    indurop_shared_locks = h ? reinterpret_cast<indurop_var_lock *>(base + h->locks_offset) : nullptr;
    indurop_shared_data = h ? base + h->data_offset : nullptr;
}

// Attach at load time when irpd started this process with INDUROP_SHM set, so that the
// generated globals work before main() runs.
__attribute__((constructor)) void attachFromEnvironment() {
    const char *name = std::getenv("INDUROP_SHM");
    if (!name || !*name) return;
    attachErrorText() = attach(name);
}

}  // namespace

void lockVariable(uint32_t lock) noexcept {
    indurop_var_lock &l = indurop_shared_locks[lock];
    int rc = pthread_mutex_lock(&l.mutex);
    if (rc == EOWNERDEAD) {
        // A writer died inside: its write may be partial, but the variable stays usable; an odd
        // sequence would make every reader spin, so close it.
        std::atomic_ref<uint32_t> seq(l.seq);
        uint32_t s = seq.load(std::memory_order_relaxed);
        if (s & 1) seq.store(s + 1, std::memory_order_release);
        pthread_mutex_consistent(&l.mutex);
        g_repaired.fetch_add(1, std::memory_order_relaxed);
    }
}

void unlockVariable(uint32_t lock) noexcept { pthread_mutex_unlock(&indurop_shared_locks[lock].mutex); }

std::string attach(const std::string &name, bool writable) {
    if (g_header) return "";  // already attached (or adopted by irpd)
    int fd = shm_open(name.c_str(), writable ? O_RDWR : O_RDONLY, 0);
    if (fd < 0) return "shared variables " + name + ": " + std::strerror(errno);
    struct stat st {};
    if (fstat(fd, &st) != 0 || static_cast<std::size_t>(st.st_size) < sizeof(indurop_segment_header)) {
        close(fd);
        return "shared variables " + name + ": not an indurop segment (too small)";
    }
    void *p = mmap(nullptr, static_cast<std::size_t>(st.st_size), writable ? PROT_READ | PROT_WRITE : PROT_READ,
                   MAP_SHARED, fd, 0);
    int e = errno;
    close(fd);
    if (p == MAP_FAILED) return "shared variables " + name + ": mmap: " + std::strerror(e);
    auto *h = static_cast<const indurop_segment_header *>(p);
    std::string problem;
    if (h->magic != INDUROP_SEGMENT_MAGIC)
        problem = "not an indurop segment (bad magic)";
    else if (h->version != INDUROP_SEGMENT_VERSION)
        problem = "segment version " + std::to_string(h->version) + ", this libindurop reads " +
                  std::to_string(INDUROP_SEGMENT_VERSION);
    else if (h->lock_size != sizeof(indurop_var_lock))
        problem = "lock size differs from this libindurop's";
    else if (h->total_size > static_cast<uint64_t>(st.st_size) || h->data_offset + h->data_size > h->total_size)
        problem = "segment shorter than its header says";
    if (!problem.empty()) {
        munmap(p, static_cast<std::size_t>(st.st_size));
        return "shared variables " + name + ": " + problem;
    }
    g_mapping = p;
    g_mapping_size = static_cast<std::size_t>(st.st_size);
    publish(h);
    return "";
}

void adopt(const indurop_segment_header *header) noexcept { publish(header); }

void detach() noexcept {
    publish(nullptr);
    if (g_mapping) munmap(g_mapping, g_mapping_size);
    g_mapping = nullptr;
    g_mapping_size = 0;
}

const indurop_segment_header *segmentHeader() noexcept { return g_header; }

void layoutCopy(std::string &hash, std::string &text) { segment::copyLayout(g_header, hash, text); }

std::string layoutHash() {
    std::string hash, text;
    layoutCopy(hash, text);
    return hash;
}

std::string layoutText() {
    std::string hash, text;
    layoutCopy(hash, text);
    return text;
}

const std::string &attachError() noexcept { return attachErrorText(); }

uint64_t repairedLocks() noexcept { return g_repaired.load(std::memory_order_relaxed); }

}  // namespace irp::shared
