// process_supervisor.cpp -- the process modules' lives: started into their control slots,
// watched, restarted per policy, stopped.  Spawning, output and the restart policy are their own
// files (process_spawn, process_output, restart_policy); see process_supervisor.hpp.
#include "hosts/process_supervisor.hpp"

#include "hosts/process_spawn.hpp"
#include "hosts/restart_policy.hpp"
#include "osal/clock.hpp"

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>

extern char **environ;

namespace irp::hosts {
namespace {

constexpr int64_t kMs = 1'000'000;
constexpr int64_t kSecond = 1'000'000'000;

int64_t now() { return osal::monotonicNow(); }

void sleepNs(int64_t ns) {
    timespec ts{static_cast<time_t>(ns / kSecond), static_cast<long>(ns % kSecond)};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {}
}

template <class T>
std::atomic_ref<T> atomic(T &word) {
    return std::atomic_ref<T>(word);
}

}  // namespace

struct ProcessSupervisor::Child {
    Child(const ProcessLaunch &l, const OutputLimits &limits, ProcessOutput::Sink sink)
        : launch(l), restarts(l.spec.process), output(l.spec.name, limits, std::move(sink)) {}

    ProcessLaunch launch;
    RestartPolicy restarts;
    ProcessOutput output;
    std::string exe, cwd;

    bool stopping = false;  // stopAll() is ending it: its exit is expected
    bool term_sent = false;
    int64_t started_ns = 0;
    int64_t restart_due_ns = 0;
    bool sched_reported = false, cpu_reported = false;

    ProcessInfo info;

    bool handshake() const {
        return launch.spec.operation != config::OperationType::NonReal && !launch.control_shm.empty();
    }
    std::string who() const { return "process module '" + launch.spec.name + "'"; }
};

ProcessSupervisor::ProcessSupervisor(Sink sink, OutputLimits limits) : sink_(std::move(sink)), limits_(limits) {
    if (!sink_)
        sink_ = [](std::string_view line) {
            std::fwrite(line.data(), 1, line.size(), stdout);
            std::fputc('\n', stdout);
            std::fflush(stdout);
        };
    devnull_ = open("/dev/null", O_RDWR | O_CLOEXEC);
    if (devnull_ >= 0 && devnull_ < 3) {
        int moved = fcntl(devnull_, F_DUPFD_CLOEXEC, 3);
        close(devnull_);
        devnull_ = moved;
    }
}

ProcessSupervisor::~ProcessSupervisor() {
    try {
        stopAll(2 * kSecond);
    } catch (...) {}
    for (auto &c : children_) c->output.close();
    if (devnull_ >= 0) close(devnull_);
}

void ProcessSupervisor::emit(std::string_view line) {
    try {
        sink_(line);
    } catch (...) {
        // a sink that throws loses the line, never the supervisor
    }
}

ProcessInfo ProcessSupervisor::infoOf(const Child &child) const {
    ProcessInfo info = child.info;
    info.lines = child.output.lines();
    info.dropped_lines = child.output.droppedLines();
    return info;
}

Result<osal::SharedMemory *> ProcessSupervisor::controlSegment(const std::string &name) {
    if (auto it = controls_.find(name); it != controls_.end()) return &it->second;
    auto shm = osal::SharedMemory::open(name, true);
    if (!shm) return shm.error();
    const auto *h = static_cast<const indurop_control_header *>(shm->data());
    if (shm->size() < sizeof *h || h->magic != INDUROP_CONTROL_MAGIC || h->version != INDUROP_CONTROL_VERSION ||
        h->slot_size != sizeof(indurop_process_slot) ||
        h->header_size + uint64_t{h->slot_count} * h->slot_size > shm->size())
        return Error{"shared memory " + name + " is not an indurop control segment of this version"};
    return &controls_.emplace(name, std::move(*shm)).first->second;
}

indurop_process_slot *ProcessSupervisor::slotOf(const Child &child) const {
    if (child.launch.control_shm.empty()) return nullptr;
    auto it = controls_.find(child.launch.control_shm);
    if (it == controls_.end()) return nullptr;
    auto *base = static_cast<char *>(it->second.data());
    const auto *h = reinterpret_cast<const indurop_control_header *>(base);
    return reinterpret_cast<indurop_process_slot *>(base + h->header_size) + child.launch.slot;
}

Status ProcessSupervisor::start(const ProcessLaunch &launch) {
    const config::ModuleSpec &spec = launch.spec;
    const std::string where = (spec.where.empty() ? "" : spec.where + ": ") + "module '" + spec.name + "': ";
    try {
        if (spec.type != config::ModuleType::Process) return Error{where + "not a process module"};
        for (const auto &c : children_)
            // The same name may run twice for a moment (a hot reload's replacement, in another slot).
            if ((c->info.running || c->info.restart_pending) && !launch.control_shm.empty() &&
                c->launch.control_shm == launch.control_shm && c->launch.slot == launch.slot)
                return Error{where + "already started (as '" + c->launch.spec.name + "' in slot " +
                             std::to_string(c->launch.slot) + ")"};

        auto child = std::make_unique<Child>(launch, limits_, [this](std::string_view line) { emit(line); });
        std::error_code ec;
        const std::filesystem::path exe = std::filesystem::absolute(spec.path, ec).lexically_normal();
        const std::string shown =
            "<filename> " + (spec.filename.empty() ? spec.path.string() : spec.filename) + " -> " + exe.string();
        if (!std::filesystem::exists(exe, ec)) return Error{where + shown + " does not exist"};
        if (!std::filesystem::is_regular_file(exe, ec)) return Error{where + shown + " is not a regular file"};
        if (access(exe.c_str(), X_OK) != 0)
            return Error{where + shown + " is not executable (" + std::strerror(errno) + "; chmod +x it)"};
        child->exe = exe.string();
        child->cwd = exe.parent_path().string();
        if (launch.rt_priority < 0 || launch.rt_priority > 99)
            return Error{where + "RT priority " + std::to_string(launch.rt_priority) + " is outside 0..99"};
        if (launch.cpu >= CPU_SETSIZE || launch.cpu < -1)
            return Error{where + "CPU " + std::to_string(launch.cpu) + " does not exist"};
        if (!launch.control_shm.empty()) {
            auto control = controlSegment(launch.control_shm);
            if (!control) return Error{where + control.error().message};
            const auto *h = static_cast<const indurop_control_header *>((*control)->data());
            if (launch.slot >= h->slot_count)
                return Error{where + "control slot " + std::to_string(launch.slot) + " out of range (" +
                             std::to_string(h->slot_count) + " slots in " + launch.control_shm + ")"};
        }
        if (devnull_ < 0) return Error{where + "cannot open /dev/null for its stdin"};

        child->info.name = spec.name;
        child->info.slot = launch.slot;
        if (Status s = spawn(*child); !s) return Error{where + s.error().message};
        child->info.starts = 1;
        // A finished earlier instance of the same module gives its place to this one.
        std::erase_if(children_, [&](const auto &c) {
            return c->launch.spec.name == spec.name && !c->info.running && !c->info.restart_pending;
        });
        children_.push_back(std::move(child));
        return Ok{};
    } catch (const std::exception &e) {
        return Error{where + "cannot start: " + e.what()};
    }
}

static_assert(static_cast<uint32_t>(config::OperationType::Periodic) == 0 &&
                  static_cast<uint32_t>(config::OperationType::Sporadic) == 1 &&
                  static_cast<uint32_t>(config::OperationType::NonReal) == 2,
              "indurop_process_slot.kind: 0 periodic, 1 sporadic, 2 non-real (control.h)");

void ProcessSupervisor::resetSlot(Child &child) {
    indurop_process_slot *s = slotOf(child);
    if (!s) return;
    // A fresh start: nothing outstanding (done_seq = release_seq), so that irpd's next release is
    // the first one the new process serves.
    atomic(s->pid).store(0, std::memory_order_relaxed);
    atomic(s->stop_requested).store(0, std::memory_order_relaxed);
    atomic(s->done_seq).store(atomic(s->release_seq).load(std::memory_order_acquire), std::memory_order_relaxed);
    atomic(s->wake_ns).store(0, std::memory_order_relaxed);  // a process that died asleep said nothing for the next
    atomic(s->kind).store(static_cast<uint32_t>(child.launch.spec.operation), std::memory_order_relaxed);
    std::snprintf(s->name, sizeof s->name, "%s", child.launch.spec.name.c_str());
    atomic(s->generation).fetch_add(1, std::memory_order_relaxed);
    atomic(s->state).store(INDUROP_PROCESS_STARTING, std::memory_order_release);
}

Status ProcessSupervisor::spawn(Child &child) {
    resetSlot(child);
    std::vector<std::pair<std::string, std::string>> set;
    if (!child.launch.control_shm.empty()) {
        set.emplace_back("INDUROP_CTL", child.launch.control_shm);
        set.emplace_back("INDUROP_SLOT", std::to_string(child.launch.slot));
    }
    if (!child.launch.variables_shm.empty()) set.emplace_back("INDUROP_SHM", child.launch.variables_shm);
    if (!child.launch.alarms_shm.empty()) {
        set.emplace_back("INDUROP_ALARMS", child.launch.alarms_shm);
        set.emplace_back("INDUROP_ALARM_SOURCE", std::to_string(child.launch.alarm_source));
    }
    set.emplace_back("INDUROP_MODULE", child.launch.spec.name);
    for (const auto &variable : child.launch.spec.process.env) set.push_back(variable);

    SpawnRequest request;
    request.exe = child.exe;
    request.cwd = child.cwd;
    request.args = child.launch.spec.process.args;
    request.env = childEnvironment(environ, set);
    request.stdin_fd = devnull_;
    request.rt_priority = child.launch.rt_priority;
    request.cpu = child.launch.cpu;
    auto spawned = spawnChild(request);
    if (!spawned) {
        if (indurop_process_slot *s = slotOf(child))
            atomic(s->state).store(INDUROP_PROCESS_EXITED, std::memory_order_release);
        return spawned.error();
    }

    child.output.attach(spawned->out_fd, spawned->err_fd);
    child.stopping = false;
    child.term_sent = false;
    child.started_ns = now();
    child.info.pid = spawned->pid;
    child.info.running = true;
    child.info.restart_pending = false;
    if (indurop_process_slot *s = slotOf(child)) atomic(s->pid).store(spawned->pid, std::memory_order_release);

    if (spawned->sched_errno && !child.sched_reported) {
        child.sched_reported = true;
        emit("irpd: " + child.who() + ": SCHED_FIFO priority " + std::to_string(request.rt_priority) + " refused (" +
             std::strerror(spawned->sched_errno) + "); it runs SCHED_OTHER, its periods are not real-time");
    }
    if (spawned->cpu_errno && !child.cpu_reported) {
        child.cpu_reported = true;
        emit("irpd: " + child.who() + ": cannot pin it to CPU " + std::to_string(request.cpu) + " (" +
             std::strerror(spawned->cpu_errno) + "); it runs on any CPU");
    }
    return Ok{};
}

// ---- exits and restarts -----------------------------------------------------------------------

void ProcessSupervisor::handleExit(Child &child, int status) {
    const pid_t pid = child.info.pid;
    child.output.read(true);  // its last words come before the news of its end
    child.output.close();
    child.output.reportDrops(true);

    const bool signaled = status >= 0 && WIFSIGNALED(status);
    child.info.running = false;
    child.info.pid = 0;
    ++child.info.exits;
    if (signaled && !child.stopping) ++child.info.crashes;
    if (status >= 0 && WIFEXITED(status) && WEXITSTATUS(status) != 0) ++child.info.failures;
    child.info.last_exit =
        status < 0 ? "ended (its exit status was lost: is SIGCHLD ignored?)" : describeWaitStatus(status);
    if (indurop_process_slot *s = slotOf(child)) {
        atomic(s->pid).store(0, std::memory_order_relaxed);
        atomic(s->state).store(INDUROP_PROCESS_EXITED, std::memory_order_release);
        futex::wakeAll(&s->state);
    }

    const std::string line = "irpd: " + child.who() + " (pid " + std::to_string(pid) + ") " + child.info.last_exit;
    if (child.stopping) {
        emit(line);
        return;
    }
    const RestartPolicy::Decision next =
        child.restarts.afterExit(status, now() - child.started_ns, child.info.restarts);
    if (next.restart) {
        child.restart_due_ns = now() + next.delay_ns;
        child.info.restart_pending = true;
    }
    emit(line + next.why);
}

void ProcessSupervisor::poll() {
    for (auto &c : children_) {
        Child &child = *c;
        try {
            if (child.info.running) {
                child.output.read();
                if (child.output.dropping()) child.output.reportDrops(false);
                int status = 0;
                const pid_t r = waitpid(child.info.pid, &status, WNOHANG);
                if (r == child.info.pid)
                    handleExit(child, status);
                else if (r < 0 && errno == ECHILD)
                    handleExit(child, -1);
            } else if (child.info.restart_pending && now() >= child.restart_due_ns) {
                child.info.restart_pending = false;
                if (Status s = spawn(child); s) {
                    ++child.info.starts;
                    ++child.info.restarts;
                    emit("irpd: " + child.who() + " restarted (pid " + std::to_string(child.info.pid) + ", restart " +
                         std::to_string(child.info.restarts) + ")");
                } else {
                    // Could not even start: count it as a failed run and try again later.
                    ++child.info.restarts;
                    child.info.last_exit = s.error().message;
                    const RestartPolicy::Decision next = child.restarts.afterFailedStart(child.info.restarts);
                    child.info.restart_pending = next.restart;
                    child.restart_due_ns = now() + next.delay_ns;
                    emit("irpd: " + child.who() + ": restart failed: " + s.error().message + next.why);
                }
            }
        } catch (...) {
            // Only allocation can throw here; the next poll() tries again.
        }
    }
}

Status ProcessSupervisor::waitReady(int64_t timeout_ns) {
    const int64_t deadline = now() + timeout_ns;
    std::vector<uint64_t> exits_before;
    for (const auto &c : children_) exits_before.push_back(c->info.exits);
    for (;;) {
        poll();
        std::string slow;
        for (std::size_t i = 0; i < children_.size(); ++i) {
            Child &child = *children_[i];
            if (!child.handshake()) continue;
            if (child.info.exits > exits_before[i])
                return Error{child.who() + " " + child.info.last_exit + " before it was ready (its output is above)"};
            if (!child.info.running) return Error{child.who() + " is not running (" + child.info.last_exit + ")"};
            indurop_process_slot *s = slotOf(child);
            const uint32_t state =
                s ? atomic(s->state).load(std::memory_order_acquire) : uint32_t{INDUROP_PROCESS_READY};
            if (state != INDUROP_PROCESS_READY && state != INDUROP_PROCESS_RUNNING)
                slow += (slow.empty() ? "'" : ", '") + child.launch.spec.name + "' (pid " +
                        std::to_string(child.info.pid) + ")";
        }
        if (slow.empty()) return Ok{};
        if (now() >= deadline)
            return Error{"process module " + slow + " not ready after " + std::to_string(timeout_ns / kMs) +
                         " ms: a periodic or sporadic process must call irp::initPeriodExe() before its loop"};
        sleepNs(2 * kMs);
    }
}

void ProcessSupervisor::stopAll(int64_t grace_ns, bool term_non_real) {
    stopWhere([](const Child &) { return true; }, grace_ns, term_non_real);
}

void ProcessSupervisor::stop(const std::vector<uint32_t> &slots, int64_t grace_ns) {
    auto chosen = [&slots](const Child &c) {
        return std::find(slots.begin(), slots.end(), c.launch.slot) != slots.end();
    };
    stopWhere(chosen, grace_ns);
    std::erase_if(children_, [&](const std::unique_ptr<Child> &c) { return chosen(*c); });
}

void ProcessSupervisor::stopWhere(const std::function<bool(const Child &)> &chosen, int64_t grace_ns,
                                  bool term_non_real) {
    bool any = false;
    for (auto &c : children_) {
        if (!chosen(*c)) continue;
        c->info.restart_pending = false;
        if (!c->info.running) continue;
        any = true;
        c->stopping = true;
        if (term_non_real && c->launch.spec.operation == config::OperationType::NonReal) {
            // Never released, it never reads the stop flag: SIGTERM is how it learns, at once
            // (waiting half the grace for a flag it does not read cost a restart a second).
            c->term_sent = true;
            if (kill(-c->info.pid, SIGTERM) != 0) kill(c->info.pid, SIGTERM);
        } else if (indurop_process_slot *s = slotOf(*c)) {
            atomic(s->stop_requested).store(1, std::memory_order_release);
            futex::wakeAll(&s->release_seq);
        }
    }
    if (!any) return;
    const int64_t start = now(), term_at = start + grace_ns / 2, kill_at = start + grace_ns;
    for (;;) {
        const int64_t t = now();
        bool alive = false;
        for (auto &c : children_) {
            Child &child = *c;
            if (!child.info.running || !chosen(child)) continue;
            const pid_t pid = child.info.pid;
            try {
                child.output.read();
            } catch (...) {}
            int status = 0;
            const pid_t r = waitpid(pid, &status, WNOHANG);
            if (r == pid || (r < 0 && errno == ECHILD)) {
                try {
                    handleExit(child, r == pid ? status : -1);
                } catch (...) {
                    child.info.running = false;
                }
                kill(-pid, SIGKILL);  // whatever it left behind in its process group
                continue;
            }
            alive = true;
            // The wake is repeated: a stop that landed between the process's check of
            // stop_requested and its futex wait would otherwise be missed.
            if (indurop_process_slot *s = slotOf(child)) futex::wakeAll(&s->release_seq);
            if (t >= kill_at) {
                kill(-pid, SIGKILL);
                kill(pid, SIGKILL);
            } else if (t >= term_at && !child.term_sent) {
                child.term_sent = true;
                if (kill(-pid, SIGTERM) != 0) kill(pid, SIGTERM);
            }
        }
        if (!alive) break;
        if (t >= kill_at + 5 * kSecond) {
            // Unkillable (stuck in the kernel): stop waiting, never hold irpd's exit on it.
            for (auto &c : children_)
                if (c->info.running && chosen(*c)) {
                    emit("irpd: " + c->who() + " (pid " + std::to_string(c->info.pid) +
                         ") survives SIGKILL; left behind");
                    c->output.close();
                    c->info.running = false;
                }
            break;
        }
        sleepNs(5 * kMs);
    }
}

std::vector<ProcessInfo> ProcessSupervisor::processes() const {
    std::vector<ProcessInfo> all;
    for (const auto &c : children_) all.push_back(infoOf(*c));
    return all;
}

std::optional<ProcessInfo> ProcessSupervisor::process(const std::string &name) const {
    std::optional<ProcessInfo> found;  // the latest of that name (a replacement comes after the original)
    for (const auto &c : children_)
        if (c->launch.spec.name == name) found = infoOf(*c);
    return found;
}

}  // namespace irp::hosts
