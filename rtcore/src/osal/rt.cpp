// rt.cpp -- POSIX/Linux calls behind rt.hpp.
#include "osal/rt.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <unistd.h>
#include <sched.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace irp::osal {

namespace {

// CAP_IPC_LOCK in the effective set, read from /proc (no libcap needed for one bit).
bool hasIpcLock() {
    FILE *f = std::fopen("/proc/self/status", "r");
    if (!f) return false;
    char line[256];
    unsigned long long caps = 0;
    while (std::fgets(line, sizeof line, f))
        if (std::sscanf(line, "CapEff: %llx", &caps) == 1) break;
    std::fclose(f);
    return caps & (1ull << 14);  // CAP_IPC_LOCK
}

}  // namespace

Status lockMemory() {
    // MCL_FUTURE under a finite RLIMIT_MEMLOCK makes every later mapping (a thread stack, a
    // buffer) fail once the limit is reached; without the privilege, lock what exists only.
    rlimit limit{};
    getrlimit(RLIMIT_MEMLOCK, &limit);
    const bool unlimited = limit.rlim_cur == RLIM_INFINITY || hasIpcLock();
    if (mlockall(unlimited ? MCL_CURRENT | MCL_FUTURE : MCL_CURRENT) != 0)
        return Error{std::string("mlockall failed: ") + std::strerror(errno) +
                     " (needs CAP_IPC_LOCK or a higher RLIMIT_MEMLOCK)"};
    if (!unlimited)
        return Error{"memory locked as it is now, but not what is mapped later (MCL_FUTURE needs CAP_IPC_LOCK or "
                     "an unlimited RLIMIT_MEMLOCK)"};
    return Ok{};
}

RtStatus makeCurrentThreadRealtime(int priority, int cpu) {
    RtStatus status;
    std::string notes;
    if (cpu >= 0) {
        cpu_set_t set;
        CPU_ZERO(&set);
        CPU_SET(cpu, &set);
        int rc = pthread_setaffinity_np(pthread_self(), sizeof set, &set);
        notes += rc == 0 ? "pinned to CPU " + std::to_string(cpu)
                         : "could not pin to CPU " + std::to_string(cpu) + ": " + std::strerror(rc);
    }
    prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);  // 1 ns: the smallest slack the kernel accepts
    sched_param param{};
    param.sched_priority = priority;
    int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
    if (rc == 0) {
        status.realtime = true;
        status.detail = "SCHED_FIFO priority " + std::to_string(priority) + ", " + notes;
    } else {
        status.detail = std::string("SCHED_FIFO refused (") + std::strerror(rc) +
                        "; needs CAP_SYS_NICE or RLIMIT_RTPRIO), running SCHED_OTHER, " + notes;
    }
    return status;
}

int holdCpuDmaLatencyZero() {
    int fd = open("/dev/cpu_dma_latency", O_WRONLY | O_CLOEXEC);
    if (fd < 0) return -1;
    const int32_t zero = 0;
    if (write(fd, &zero, sizeof zero) != sizeof zero) {
        close(fd);
        return -1;
    }
    return fd;
}

void prefaultStack(std::size_t bytes) {
    auto *buffer = static_cast<volatile unsigned char *>(__builtin_alloca(bytes));
    for (std::size_t i = 0; i < bytes; i += 4096) buffer[i] = 0;
}

// The CPUs this process could use when first asked: the thread that asks may since have been
// kept off the RT CPUs (keepOffCpus), the process has not.
static const cpu_set_t &startupCpus() {
    static const cpu_set_t set = [] {
        cpu_set_t s;
        CPU_ZERO(&s);
        if (sched_getaffinity(0, sizeof s, &s) != 0) CPU_SET(0, &s);
        return s;
    }();
    return set;
}

int lastAllowedCpu() {
    for (int cpu = CPU_SETSIZE - 1; cpu >= 0; --cpu)
        if (CPU_ISSET(cpu, &startupCpus())) return cpu;
    return 0;
}

bool cpuAllowed(int cpu) {
    if (cpu < 0 || cpu >= CPU_SETSIZE) return false;
    return CPU_ISSET(cpu, &startupCpus());
}

std::string keepOffCpus(const std::vector<int> &rt_cpus) {
    cpu_set_t rest = startupCpus();
    for (int cpu : rt_cpus)
        if (cpu >= 0 && cpu < CPU_SETSIZE) CPU_CLR(cpu, &rest);
    if (CPU_COUNT(&rest) == 0) return "";
    if (sched_setaffinity(0, sizeof rest, &rest) != 0) return "";
    std::string list;
    for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu)
        if (CPU_ISSET(cpu, &rest)) list += (list.empty() ? "" : ",") + std::to_string(cpu);
    return list;
}

void restoreStartupCpus() { sched_setaffinity(0, sizeof(cpu_set_t), &startupCpus()); }

namespace {
constexpr std::size_t kSignalStackBytes = 64 * 1024;
}

void *useAlternateSignalStack() {
    void *stack = mmap(nullptr, kSignalStackBytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (stack == MAP_FAILED) return nullptr;
    std::memset(stack, 0, kSignalStackBytes);  // faulted in now (and locked, after mlockall)
    stack_t ss{};
    ss.ss_sp = stack;
    ss.ss_size = kSignalStackBytes;
    if (sigaltstack(&ss, nullptr) != 0) {
        munmap(stack, kSignalStackBytes);
        return nullptr;
    }
    return stack;
}

void releaseAlternateSignalStack(void *stack) {
    if (!stack) return;
    stack_t off{};
    off.ss_flags = SS_DISABLE;
    sigaltstack(&off, nullptr);
    munmap(stack, kSignalStackBytes);
}

}  // namespace irp::osal
