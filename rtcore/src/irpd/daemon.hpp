// daemon.hpp -- irpd from start to clean stop: set -> schedule -> modules -> dispatchers -> stats.
#pragma once

#include "irpd/options.hpp"

namespace irp::daemon {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitRefused = 2;  // bad module.xml, module refused, schedule refused

// Runs irpd with parsed options; returns the process exit status.  SIGINT and SIGTERM must be
// blocked in the calling thread (main() does it before any thread exists).
int run(const Options &options);

} // namespace irp::daemon
