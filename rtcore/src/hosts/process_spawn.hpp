// process_spawn.hpp -- starts one child process the way irpd must: without copying irpd's locked
// memory and without a page fault on its RT thread (clone(CLONE_VM | CLONE_VFORK), as posix_spawn
// does), and without handing it anything of irpd's but what is asked for.
//
// The child: argv[0] = exe, cwd as asked, exactly the environment given; stdin from stdin_fd,
// stdout and stderr into pipes whose read ends come back; no other inherited fd; its own process
// group; killed when the thread that spawned it ends (PR_SET_PDEATHSIG: spawn from a thread that
// outlives it); signal mask and dispositions reset; no ambient capability; SCHED_FIFO at
// rt_priority (0: SCHED_OTHER) and pinned to cpu when asked.  A refused SCHED_FIFO or pinning does
// not fail the spawn: the child runs without, and the errno comes back for a report.
#pragma once

#include <indurop/result.hpp>

#include <sys/types.h>

#include <string>
#include <utility>
#include <vector>

namespace irp::hosts {

struct SpawnRequest {
    std::string exe;  // absolute path; also argv[0]
    std::string cwd;
    std::vector<std::string> args;  // after argv[0]
    std::vector<std::string> env;   // the whole environment, NAME=value
    int stdin_fd = -1;              // installed as its fd 0 (must be >= 3)
    int rt_priority = 0;            // SCHED_FIFO priority, 0 = SCHED_OTHER
    int cpu = -1;                   // pin to this CPU, -1 = no pinning
};

struct Spawned {
    pid_t pid = -1;
    int out_fd = -1,
        err_fd = -1;      // read ends of its stdout and stderr: non-blocking, close-on-exec, owned by the caller
    int sched_errno = 0;  // SCHED_FIFO refused: it runs SCHED_OTHER
    int cpu_errno = 0;    // pinning refused: it runs on any CPU
};

// Starts the child.  An Error says which step failed ("cannot start /x/y.exe: execve: Permission
// denied"); the child is reaped and nothing is left open then.
Result<Spawned> spawnChild(const SpawnRequest &request);

// A child's environment: `base` (irpd's own, `environ`) without irpd's variables
// (config::isIrpdVariable) and without the names of `set`, then `set` in order.
std::vector<std::string> childEnvironment(char *const *base,
                                          const std::vector<std::pair<std::string, std::string>> &set);

// A wait status in words: "exited with status 3", "killed by SIGSEGV (Segmentation fault)", ...
std::string describeWaitStatus(int status);

}  // namespace irp::hosts
