// restart_policy.hpp -- what follows a process module's exit, per its `restart`,
// `restart_delay_ms` and `max_restarts` properties (config/process_properties.hpp): a restart
// after a delay that doubles for each quick failure in a row, or no restart, and why.
//
//   restart=always      every exit is followed by a restart; on-failure: a signal, a non-zero
//                       status or a lost status; never: none;
//   status 78           a process built against another shared-variable layout: never restarted;
//   max_restarts        at most this many restarts in all (a failed spawn counts);
//   the delay           restart_delay_ms, doubled for each consecutive restart up to 10 s, back to
//                       restart_delay_ms once a run lasted 10 s.
//
// No clock and no process here: the supervisor says how long the run lasted and how many
// restarts it counted, and acts on the decision.
#pragma once

#include "config/process_properties.hpp"

#include <cstdint>
#include <string>

namespace irp::hosts {

class RestartPolicy {
public:
    struct Decision {
        bool restart = false;
        int64_t delay_ns = 0;  // when restart
        std::string why;       // for the exit's log line: "; restarting in 100 ms (restart=on-failure)"
    };

    explicit RestartPolicy(const config::ProcessProperties &properties)
        : policy_(properties.restart),
          first_delay_ns_(properties.restart_delay_ns),
          max_restarts_(properties.max_restarts) {}

    // After an exit with wait status `status` (-1: lost) of a run that lasted ran_ns; `restarts`:
    // the restarts so far.
    Decision afterExit(int status, int64_t ran_ns, uint64_t restarts);
    // After a restart whose spawn failed; `restarts` counts that one already.
    Decision afterFailedStart(uint64_t restarts);

    config::RestartPolicy policy() const { return policy_; }

private:
    int64_t nextDelay();  // the backoff, one step further

    config::RestartPolicy policy_;
    int64_t first_delay_ns_;
    int64_t max_restarts_;  // -1 = unlimited
    int consecutive_ = 0;   // quick restarts in a row (the backoff exponent)
};

// The status a process module exits with when it refuses the running shared-variable layout
// (libindurop, docs/process-modules.md).
inline constexpr int kExitLayoutRefused = 78;

}  // namespace irp::hosts
