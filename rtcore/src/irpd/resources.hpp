// resources.hpp -- the parts of irpd's start-up that are no object of their own elsewhere, each
// made one here so that its destructor undoes it (irpd/daemon.cpp builds them in order and
// releases them in reverse):
//
//   DmaLatencyHold      /dev/cpu_dma_latency held at 0 while irpd dispatches; closed at the end
//                       unless handed to a managed restart's next image (or, when this image of a
//                       restart fails to start, left to the fallback image main() executes);
//   ArmedCrashHandler   the crash handler armed on the state folder's records; disarmed at the end;
//   FirstGeneration     the set's first generation from its start until the dispatcher runs it:
//                       a start-up that fails before stops its processes and its thread modules.
#pragma once

#include "hosts/process_supervisor.hpp"
#include "irpd/restart.hpp"
#include "reload/generation.hpp"
#include "supervise/crash_record.hpp"

#include <memory>
#include <optional>

namespace irp::daemon {

class DmaLatencyHold {
public:
    DmaLatencyHold() = default;
    // The descriptor the previous image of a managed restart kept open (it may no longer be root
    // enough to open it), else opened now.  Not held when neither works (a note says so later).
    static DmaLatencyHold take(const std::optional<RestartPlan> &arrived);
    ~DmaLatencyHold();
    DmaLatencyHold(DmaLatencyHold &&other) noexcept : fd_(other.fd_), inherited_(other.inherited_) { other.fd_ = -1; }
    DmaLatencyHold &operator=(DmaLatencyHold &&other) noexcept;

    bool held() const { return fd_ >= 0; }
    // The descriptor for the next image of a managed restart (RestartPlan::dma_latency_fd); no
    // longer closed here.  -1 when not held.
    int handOver() {
        const int fd = fd_;
        fd_ = -1;
        return fd;
    }
    // A start that failed: the descriptor the previous image handed over stays open for the
    // fallback image (main.cpp executes it with the same plan); one opened here is closed.
    void leaveInheritedOpen() {
        if (inherited_) fd_ = -1;
    }

private:
    DmaLatencyHold(int fd, bool inherited) : fd_(fd), inherited_(inherited) {}
    int fd_ = -1;
    bool inherited_ = false;  // the previous image's descriptor (RestartPlan::dma_latency_fd)
};

class ArmedCrashHandler {
public:
    ArmedCrashHandler() = default;
    // Arms crash's handler (process-wide, before any thread exists).
    static Result<ArmedCrashHandler> arm(supervise::CrashState &crash);
    ~ArmedCrashHandler() { disarm(); }
    ArmedCrashHandler(ArmedCrashHandler &&other) noexcept : crash_(other.crash_) { other.crash_ = nullptr; }
    ArmedCrashHandler &operator=(ArmedCrashHandler &&other) noexcept;

    // The handlers back to the default (a clean stop does it before the modules are unloaded).
    void disarm();

private:
    explicit ArmedCrashHandler(supervise::CrashState *crash) : crash_(crash) {}
    supervise::CrashState *crash_ = nullptr;
};

class FirstGeneration {
public:
    FirstGeneration(std::unique_ptr<reload::Generation> generation, hosts::ProcessSupervisor &supervisor)
        : generation_(std::move(generation)), supervisor_(supervisor) {}
    // Not adopted: every process stopped (1 s grace), then every started thread module's stop().
    ~FirstGeneration();
    FirstGeneration(const FirstGeneration &) = delete;
    FirstGeneration &operator=(const FirstGeneration &) = delete;

    reload::Generation &operator*() const { return *generation_; }
    reload::Generation *operator->() const { return generation_.get(); }
    // The dispatcher runs it: the reloader owns it from now on (Reloader::adopt).
    std::unique_ptr<reload::Generation> adopt() { return std::move(generation_); }

private:
    std::unique_ptr<reload::Generation> generation_;
    hosts::ProcessSupervisor &supervisor_;
};

}  // namespace irp::daemon
