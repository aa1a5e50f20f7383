// process.h -- the SDK of process modules: an executable that irpd starts, releases every period
// (or on an event) and awaits, and that reaches the shared variables by path (paper, Figure 8).
//
//   #include <indurop/indurop.h>          // includes this header
//   int main() {
//       channel::Handle handle;
//       if (irp::initPeriodExe() != 0) return 1;   // READY: irpd may release us from now on
//       channel::connect(handle);
//       while (irp::waitPeriod() == 0) {           // reports the last period done, waits for the next
//           double y;
//           if (read(handle, "joint[1].y", sizeof y, &y) == sizeof y) { ... }
//       }
//       return 0;                                  // irpd asked us to stop
//   }
//
// Build it with indurop_add_process(name SOURCES ... [GLB target]) (cmake/InduropModule.cmake):
// an executable name.exe linked to libindurop, its symbols exported so that libindurop can see
// which shared-variable layout it was compiled against.  module.xml names it with
// <moduletype>process</moduletype>; periodic, sporadic and non-real operation types all apply.
//
// How irpd runs it (rtcore/src/hosts/process_supervisor.hpp has the details):
//   - environment: INDUROP_CTL (the control segment), INDUROP_SLOT (this process's slot in it),
//     INDUROP_SHM (the shared-variable segment, attached by libindurop before main()),
//     INDUROP_MODULE (the module's name), plus the module's env.NAME properties;
//     argv: the module's `args` property; working directory: the executable's folder;
//   - stdout and stderr go to irpd's log, one line = one "[name] ..." entry, rate-limited:
//     flush after each line (a pipe is block-buffered) and keep output rare in the period;
//   - stdin is /dev/null, no other descriptor of irpd's is inherited, it leads its own process group;
//   - a periodic or sporadic process runs SCHED_FIFO at the priority irpd gives it (SCHED_OTHER,
//     reported once, where irpd may not grant it), pinned to irpd's RT CPU if irpd says so; it
//     should mlockall() itself if it must never page-fault.  A non-real process runs SCHED_OTHER
//     and needs none of the period calls below (it may still use channels);
//   - it dies with irpd (PR_SET_PDEATHSIG), and irpd restarts it per its `restart` property
//     (never | always | on-failure), with a growing delay; stopping ends it with SIGTERM, then SIGKILL.
//
// The period handshake goes through the control slot with futexes (<indurop/control.h>); no
// signal is used, so these calls never interrupt the program.
//
// Functions exported by thread modules are called through irpd with irp::SharedFunction or
// irp::callFunction (<indurop/functions.h>, docs/shared-variables.md "Shared functions"): served
// right after the owner's run(), in its slot, with a timeout; from any process module.
//
// Real-time safety (for a process at SCHED_FIFO):
//   - initPeriodExe() and channel::connect() allocate and may block: call them before the loop;
//   - waitPeriod() is RT-safe (a futex wait and a few stores);
//   - read()/write() of a path resolved before are RT-safe: no allocation, no syscall except
//     the variable's priority-inheritance lock for a write, or for a read that finds a writer
//     inside 64 times in a row.  The FIRST use of each path parses the layout and allocates:
//     touch every path once before the loop (a read into a scratch variable is enough).
//   - an error on a cached path (wrong size) formats its message into the handle: no allocation.
#pragma once

#include <cstddef>
#include <memory>

namespace irp {

// Joins irpd's period handshake: maps the control segment named by INDUROP_CTL, takes slot
// INDUROP_SLOT and marks it READY, after which irpd may release this process.  Checks that the
// executable was built against the running shared-variable layout: a process whose
// <indurop/generated.h> has another layout hash, or that uses shared variables while irpd gave
// it none, prints both hashes on stderr and exits with status 78 (EX_CONFIG) at once -- irpd does
// not restart a process that exits 78.
// Returns 0, or -1 with the reason on stderr: not started by irpd (INDUROP_CTL unset), a
// malformed or foreign control segment, a bad slot, or a shared-variable segment that could not
// be attached.  Calling it again after success returns 0 and does nothing.  Not RT-safe.
int initPeriodExe();

// The period loop's one call.  If the process is inside a release (this is not the first call
// since initPeriodExe), it first reports that release done (done_ns, done_seq; irpd's wait on
// it ends).  Then it waits until irpd releases the process again, and returns 0 with
// irp::cycle() set to the release's cycle: count = irpd's basic-period counter, planned_ns = when
// the basic period was due, basic_ns = the basic period, slot = the low 32 bits of count (the
// control slot does not carry irpd's slot-table index).  irp::cycle() is per thread: it is set
// on the thread that called waitPeriod().
// Returns -1 when irpd asked the process to stop (leave the loop and return from main; irpd sends
// SIGTERM if it does not, after a grace period), and at once when initPeriodExe() has not succeeded.  Calling it again after it returned -1 for a stop
// ends the process with exit(0), so that a loop that ignores the result (as Figure 8 does) still
// leaves.  RT-safe.
int waitPeriod();

}  // namespace irp

// Shared variables by path (Figure 8's `channel::Handle`).  Named "channel" as in the paper: a
// handle is this process's view of the shared-variable segment irpd gave it (INDUROP_SHM), with
// a cache of the paths it resolved.  Generated globals (<indurop/generated.h>) need a build
// against the .glb files; a channel needs only the path, resolved from the layout stored in
// the segment, so one executable works with any layout that has the variables it names.
//
// Paths name, as in layout.json (docs/glbc.md):
//   - a whole top-level variable:          "knu.Robot.tick", "joint", "knu.Robot.joints"
//   - an element of an array, any depth:   "joint[1]", "m[1][2]", "m[1]" (a whole row)
//   - a struct member, any depth:          "joint[1].y", "test.cell.rec[0].inner.v[2]"
//   - without the namespace, when exactly one namespace has that variable: "joints[3].x"
// Indices are decimal and checked against the dimensions.  read/write move exactly the named
// object's bytes, in the layout's (native) representation: `size` must equal its size.
//
// A handle is used by one thread at a time; use one handle per thread.  It may be moved, not copied.
namespace channel {
class Handle;
}

// read(handle, path, size, out): copies the object named by path into out, a consistent
// snapshot (never a torn struct or array).  Returns size, or -1 and channel::lastError(handle)
// says why: unknown path, index out of range, size differs from the object's, no segment.
// An unconnected handle is connected first.
//
// write(handle, path, size, in): writes size bytes from in to the object named by path, under
// its variable's lock (readers see the old or the new value, never a mix).  Returns size, or -1
// as read does.
//
// Both overload POSIX read/write by their first parameter; neither throws.
int read(channel::Handle &handle, const char *path, std::size_t size, void *out);
int write(channel::Handle &handle, const char *path, std::size_t size, const void *in);

namespace channel {

class Handle {
public:
    Handle() noexcept;
    ~Handle();
    Handle(Handle &&other) noexcept;
    Handle &operator=(Handle &&other) noexcept;
    Handle(const Handle &) = delete;
    Handle &operator=(const Handle &) = delete;

private:
    struct Impl;
    friend struct Access;
    std::unique_ptr<Impl> impl_;  // the segment, its parsed layout, the resolved paths
    char error_[256];             // the last failure (no allocation to report one)
};

// Binds the handle to this process's shared-variable segment (attached by libindurop from
// INDUROP_SHM before main(), or by the host).  Returns 0, or -1 when there is none (not
// started with variables, or the attach failed; lastError says which).  Reconnecting drops
// the cached paths.  Not RT-safe (allocates).
int connect(Handle &handle);

// The reason of the handle's last failed call ("" after a success).  Valid until the next call.
const char *lastError(const Handle &handle) noexcept;

}  // namespace channel
