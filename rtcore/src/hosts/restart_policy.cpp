// restart_policy.cpp -- a process module's restart after an exit, with its backoff; see
// restart_policy.hpp.
#include "hosts/restart_policy.hpp"

#include <sys/wait.h>

#include <algorithm>

namespace irp::hosts {
namespace {
constexpr int64_t kMs = 1'000'000;
constexpr int64_t kStableRunNs = 10'000'000'000;  // running this long resets the backoff
}  // namespace

int64_t RestartPolicy::nextDelay() {
    int64_t delay = first_delay_ns_;
    for (int i = 0; i < consecutive_ && delay < config::kMaxRestartDelayNs; ++i) delay *= 2;
    ++consecutive_;
    return std::min(delay, config::kMaxRestartDelayNs);
}

RestartPolicy::Decision RestartPolicy::afterExit(int status, int64_t ran_ns, uint64_t restarts) {
    const bool signaled = status >= 0 && WIFSIGNALED(status);
    const bool failed = status < 0 || signaled || WEXITSTATUS(status) != 0;
    const bool wanted =
        policy_ == config::RestartPolicy::Always || (policy_ == config::RestartPolicy::OnFailure && failed);
    Decision d;
    if (status >= 0 && WIFEXITED(status) && WEXITSTATUS(status) == kExitLayoutRefused) {
        d.why =
            "; not restarted: it refused the running shared-variable layout (rebuild it against the set's .glb files)";
    } else if (!wanted) {
        d.why = std::string("; not restarted (restart=") + config::toString(policy_) + ")";
    } else if (max_restarts_ >= 0 && static_cast<int64_t>(restarts) >= max_restarts_) {
        d.why = "; not restarted: max_restarts " + std::to_string(max_restarts_) + " reached";
    } else {
        if (ran_ns >= kStableRunNs) consecutive_ = 0;
        d.restart = true;
        d.delay_ns = nextDelay();
        d.why =
            "; restarting in " + std::to_string(d.delay_ns / kMs) + " ms (restart=" + config::toString(policy_) + ")";
    }
    return d;
}

RestartPolicy::Decision RestartPolicy::afterFailedStart(uint64_t restarts) {
    Decision d;
    d.delay_ns = nextDelay();
    d.restart = max_restarts_ < 0 || static_cast<int64_t>(restarts) < max_restarts_;
    d.why = d.restart ? "; next try in " + std::to_string(d.delay_ns / kMs) + " ms" : "; max_restarts reached";
    return d;
}

}  // namespace irp::hosts
