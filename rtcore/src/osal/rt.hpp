// rt.hpp -- making a thread real-time: memory locking, SCHED_FIFO, CPU pinning, timer slack.
#pragma once

#include <indurop/result.hpp>

#include <string>
#include <vector>

namespace irp::osal {

struct RtStatus {
    bool realtime = false;  // SCHED_FIFO obtained
    std::string detail;     // what was done, or why not
};

// mlockall(MCL_CURRENT | MCL_FUTURE): no page faults on the RT path later.
Status lockMemory();

// For the calling thread: pin to cpu (-1 = leave as is), minimum timer slack, and SCHED_FIFO at
// priority (1..99).  Pinning and slack are applied even when SCHED_FIFO is refused.
RtStatus makeCurrentThreadRealtime(int priority, int cpu);

// Asks the kernel for the lowest CPU wake-up latency (no deep idle states) for as long as the
// returned descriptor stays open, as cyclictest does (/dev/cpu_dma_latency = 0).  -1 on failure.
int holdCpuDmaLatencyZero();

// Touches `bytes` of stack so the RT loop never faults a stack page in.
void prefaultStack(std::size_t bytes = 256 * 1024);

// Gives the calling thread an alternate signal stack (sigaltstack) of its own, so that a crash
// handler still runs when the thread's stack is what broke.  Returns it for release at the
// thread's end (null if it could not be set up).
void *useAlternateSignalStack();
void releaseAlternateSignalStack(void *stack);

// The highest CPU number this process may run on (the default RT CPU), and whether cpu is usable.
int lastAllowedCpu();
bool cpuAllowed(int cpu);

// Restricts the calling thread (and the threads and processes it creates from now on, unless
// they pin themselves) to the CPUs irpd may use minus rt_cpus, so that irpd's non-RT work never
// competes with a dispatcher.  Returns the CPUs left ("0,2"), or "" when none would be left
// (nothing changed then).  lastAllowedCpu() and cpuAllowed() still answer for the whole process.
std::string keepOffCpus(const std::vector<int> &rt_cpus);
// The calling thread back on every CPU the process started with (undoes keepOffCpus; before irpd
// executes itself again, so that the next image finds the same CPUs).
void restoreStartupCpus();

}  // namespace irp::osal
