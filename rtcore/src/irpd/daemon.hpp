// daemon.hpp -- irpd from start to clean stop: set -> schedule -> modules -> dispatchers -> stats.
#pragma once

#include "irpd/options.hpp"
#include "irpd/restart.hpp"

#include <cstdint>
#include <optional>
#include <string>

namespace irp::daemon {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitRefused = 2;  // bad module.xml, module refused, schedule refused

// One image of irpd: how it came to be, and how it ended.
struct Session {
    int64_t began_ns = 0;                // CLOCK_MONOTONIC at main()'s start: start-up is measured from it
    std::optional<RestartPlan> arrived;  // this image is a managed restart (INDUROP_RESTART)
    // Set by run():
    Error error;                         // the failure it returned with
    bool dispatched = false;             // the set ran (a later failure is no refusal at start)
    std::optional<RestartPlan> restart;  // a managed restart was asked: main() executes it
};

// Runs irpd with parsed options; returns the process exit status.  SIGINT and SIGTERM must be
// blocked in the calling thread (main() does it before any thread exists).
int run(const Options &options, Session &session);

}  // namespace irp::daemon
