// process_supervisor.hpp -- starts the process modules of a set (periodic, sporadic, non-real),
// watches them, restarts them per policy and stops them; irpd's non-RT side.  The concerns live
// apart: spawning (hosts/process_spawn.hpp), output limits (hosts/process_output.hpp), restart
// policy (hosts/restart_policy.hpp), and the properties, parsed with module.xml
// (config/process_properties.hpp).  This class ties them to the control slots.
//
// One supervisor per irpd, used from one long-lived thread (irpd's main thread): the children
// die with the thread that started them (PR_SET_PDEATHSIG), so never call start() or poll()
// from a thread that ends before irpd does.  The RT dispatcher never calls it; it talks to the
// processes through their control slots only (<indurop/control.h>).
//
//   start(launch)      checks the module's file, priority, CPU and control slot, resets its slot
//                      (STARTING, generation + 1, done_seq = release_seq) and spawns it;
//   waitReady(t)       until every started periodic or sporadic process reached READY;
//   poll()             every ~20 ms: forwards output lines, reaps exits, restarts when due;
//   stopAll(grace)     stop_requested + wake, SIGTERM, SIGKILL of the process group after grace.
//
// The child gets INDUROP_CTL, INDUROP_SLOT, INDUROP_SHM (when the set has variables),
// INDUROP_ALARMS and INDUROP_ALARM_SOURCE (the alarm segment and its source there, when irpd has
// one), INDUROP_MODULE and its env.* properties besides irpd's environment; argv[0] is the
// module's absolute path, its folder the working directory.
//
// irpd must not set SIGCHLD to SIG_IGN (exits could not be reaped).  Nothing a child does makes
// the supervisor throw or crash.
#pragma once

#include <indurop/result.hpp>
#include "config/module_xml.hpp"
#include "hosts/process_output.hpp"
#include "osal/shm.hpp"

#include <indurop/control.h>

#include <sys/types.h>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace irp::hosts {

struct ProcessLaunch {
    config::ModuleSpec spec;    // path, name, its parsed properties (spec.process), where (for messages)
    uint32_t slot = 0;          // its control slot
    int rt_priority = 0;        // SCHED_FIFO priority, 0 = SCHED_OTHER (non-real modules)
    int cpu = -1;               // pin to this CPU, -1 = no pinning
    std::string control_shm;    // INDUROP_CTL
    std::string variables_shm;  // INDUROP_SHM ("" = no variables)
    std::string alarms_shm;     // INDUROP_ALARMS ("" = no alarm segment)
    uint32_t alarm_source = 0;  // INDUROP_ALARM_SOURCE: its source there
};

// What one process module did so far.
struct ProcessInfo {
    std::string name;
    uint32_t slot = 0;
    pid_t pid = 0;  // 0 while not running
    bool running = false;
    bool restart_pending = false;
    uint64_t starts = 0;         // successful spawns, the first included
    uint64_t exits = 0;          // every end, whatever the cause
    uint64_t crashes = 0;        // killed by a signal irpd did not send
    uint64_t failures = 0;       // exited with a non-zero status
    uint64_t restarts = 0;       // restart attempts after an exit (a spawn that failed included)
    uint64_t lines = 0;          // output lines forwarded
    uint64_t dropped_lines = 0;  // output lines dropped by the rate limit
    std::string last_exit;       // "exited with status 3", "killed by SIGSEGV (Segmentation fault)", ...
};

class ProcessSupervisor {
public:
    // Where forwarded output and the supervisor's own lines go (one line, no newline).
    using Sink = std::function<void(std::string_view line)>;

    // sink defaults to irpd's stdout.
    explicit ProcessSupervisor(Sink sink = {}, OutputLimits limits = {});
    ~ProcessSupervisor();  // stopAll(2 s) if anything still runs
    ProcessSupervisor(const ProcessSupervisor &) = delete;
    ProcessSupervisor &operator=(const ProcessSupervisor &) = delete;

    // Checks the launch (file, priority, CPU, control slot) and spawns the process.  An Error
    // names the module.xml line, the module and what is wrong; nothing is started then.  Its
    // properties were checked when module.xml was read (spec.process).
    Status start(const ProcessLaunch &launch);

    // Waits until every started periodic and sporadic process is READY (it called
    // irp::initPeriodExe()), forwarding output meanwhile.  Non-real processes are not waited for.
    // An Error names the process that exited or was still not ready at the timeout.
    Status waitReady(int64_t timeout_ns);

    // Non-blocking: forwards output, reaps exits (logged, counted), restarts what is due.
    void poll();

    // Ends every child: stop_requested and a wake of its release word, SIGTERM after half the
    // grace, SIGKILL to its process group at the end of it; reaps them all.  No restart follows.
    // term_non_real: SIGTERM the non-real processes at once instead of half the grace later (they
    // never read the stop flag; a managed restart should not wait for them).
    void stopAll(int64_t grace_ns, bool term_non_real = false);
    // The same for the processes in these control slots only, which are then forgotten (a hot
    // reload removed or replaced them).
    void stop(const std::vector<uint32_t> &slots, int64_t grace_ns);

    std::vector<ProcessInfo> processes() const;
    std::optional<ProcessInfo> process(const std::string &name) const;

private:
    struct Child;
    void emit(std::string_view line);
    Status spawn(Child &child);
    void resetSlot(Child &child);
    void handleExit(Child &child, int status);
    void stopWhere(const std::function<bool(const Child &)> &chosen, int64_t grace_ns, bool term_non_real = false);
    indurop_process_slot *slotOf(const Child &child) const;
    Result<osal::SharedMemory *> controlSegment(const std::string &name);
    ProcessInfo infoOf(const Child &child) const;

    Sink sink_;
    OutputLimits limits_;
    std::vector<std::unique_ptr<Child>> children_;
    std::map<std::string, osal::SharedMemory> controls_;  // mapped control segments by name
    int devnull_ = -1;
};

}  // namespace irp::hosts
