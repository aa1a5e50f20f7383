// privileges.hpp -- irpd starts as root (SCHED_FIFO, mlockall, /dev/cpu_dma_latency) and then, with
// --user, becomes that user keeping only what it still needs (libcap): CAP_SYS_NICE, for
// SCHED_FIFO and CPU pinning of the dispatcher threads and of the process modules a hot reload
// starts, and CAP_IPC_LOCK, for mlockall(MCL_FUTURE), which locks every later mapping (a newly
// loaded module's code, heap growth) beyond RLIMIT_MEMLOCK.  Everything else leaves the bounding
// set, and no_new_privs is set: nothing irpd or a module executes can gain privileges again.
#pragma once

#include <indurop/result.hpp>

#include <sys/types.h>

#include <filesystem>
#include <string>

namespace irp::supervise {

struct Identity {
    std::string user, group;
    uid_t uid = 0;
    gid_t gid = 0;
};

// --user USER [--group GROUP] (default: the user's primary group).  The Error names what is unknown.
Result<Identity> resolveIdentity(const std::string &user, const std::string &group);

// Makes `dir` (created if missing) belong to `who`, for the files irpd writes after the switch.
Status handOver(const std::filesystem::path &dir, const Identity &who);

// The folder of a file `who` will create after the switch (the control socket): created for `who`
// (mode 0750, its group may enter) when missing; an Error naming the folder when it exists and
// `who` may not create files in it.
Status prepareFolderFor(const std::filesystem::path &file, const Identity &who);

// Becomes `who` with exactly CAP_SYS_NICE and CAP_IPC_LOCK (permitted, effective, inheritable and
// ambient -- ambient so that they survive irpd's exec of itself in a managed restart; the bounding
// set the same) and no_new_privs.  Must be called while the process has one thread (capabilities
// are per thread); refused otherwise.  A process that is `who` already (the image a restart
// started) is accepted when it has the two capabilities effective, refused naming the missing one.
Status dropPrivileges(const Identity &who);

// "uid 65534 gid 65534, cap_ipc_lock,cap_sys_nice=ep", for the log.
std::string describeCredentials();

}  // namespace irp::supervise
