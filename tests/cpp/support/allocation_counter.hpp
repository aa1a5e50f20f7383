// allocation_counter.hpp -- counts the calls to malloc and its kin made by one thread, to check
// that code meant for run() allocates nothing.  It replaces malloc, calloc, realloc, aligned_alloc
// and posix_memalign for the whole executable (they forward to glibc's), so include it in exactly
// one source file of a test executable.
#pragma once

#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdlib>  // glibc's declarations first: these definitions match them (noexcept)

extern "C" void *__libc_malloc(size_t);
extern "C" void *__libc_calloc(size_t, size_t);
extern "C" void *__libc_realloc(void *, size_t);
extern "C" void *__libc_memalign(size_t, size_t);

namespace testing_support {
inline std::atomic<long> g_allocations{0};
inline thread_local bool g_counting = false;
inline void countAllocation() {
    if (g_counting) g_allocations.fetch_add(1, std::memory_order_relaxed);
}

// Counts the allocations made by the calling thread while it lives.
class AllocationCounter {
public:
    AllocationCounter() : start_(g_allocations.load()) { g_counting = true; }
    ~AllocationCounter() { g_counting = false; }
    long count() const { return g_allocations.load() - start_; }

private:
    long start_;
};
}  // namespace testing_support

extern "C" {
void *malloc(size_t n) noexcept { return testing_support::countAllocation(), __libc_malloc(n); }
void *calloc(size_t n, size_t m) noexcept { return testing_support::countAllocation(), __libc_calloc(n, m); }
void *realloc(void *p, size_t n) noexcept { return testing_support::countAllocation(), __libc_realloc(p, n); }
void *aligned_alloc(size_t a, size_t n) noexcept { return testing_support::countAllocation(), __libc_memalign(a, n); }
int posix_memalign(void **out, size_t a, size_t n) noexcept {
    testing_support::countAllocation();
    *out = __libc_memalign(a, n);
    return *out ? 0 : ENOMEM;
}
}
