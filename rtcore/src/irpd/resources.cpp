// resources.cpp -- /dev/cpu_dma_latency, the armed crash handler and the first generation as
// owned resources; see resources.hpp.
#include "irpd/resources.hpp"

#include "osal/rt.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <filesystem>

namespace irp::daemon {

DmaLatencyHold DmaLatencyHold::take(const std::optional<RestartPlan> &arrived) {
    if (arrived && arrived->dma_latency_fd >= 0) {
        const int fd = arrived->dma_latency_fd;
        std::error_code ec;
        if (std::filesystem::read_symlink("/proc/self/fd/" + std::to_string(fd), ec) == "/dev/cpu_dma_latency") {
            fcntl(fd, F_SETFD, FD_CLOEXEC);
            return DmaLatencyHold(fd, true);
        }
    }
    return DmaLatencyHold(osal::holdCpuDmaLatencyZero(), false);
}

DmaLatencyHold::~DmaLatencyHold() {
    if (fd_ >= 0) close(fd_);
}

DmaLatencyHold &DmaLatencyHold::operator=(DmaLatencyHold &&other) noexcept {
    if (this != &other) {
        if (fd_ >= 0) close(fd_);
        inherited_ = other.inherited_;
        fd_ = other.handOver();
    }
    return *this;
}

Result<ArmedCrashHandler> ArmedCrashHandler::arm(supervise::CrashState &crash) {
    if (Status st = crash.arm(); !st) return st.error();
    return ArmedCrashHandler(&crash);
}

ArmedCrashHandler &ArmedCrashHandler::operator=(ArmedCrashHandler &&other) noexcept {
    if (this != &other) {
        disarm();
        crash_ = other.crash_;
        other.crash_ = nullptr;
    }
    return *this;
}

void ArmedCrashHandler::disarm() {
    if (crash_) crash_->disarm();
    crash_ = nullptr;
}

FirstGeneration::~FirstGeneration() {
    if (!generation_) return;
    supervisor_.stopAll(1'000'000'000);
    for (const reload::Member &m : generation_->members)
        if (m.thread) (void)m.thread->stop();
}

}  // namespace irp::daemon
