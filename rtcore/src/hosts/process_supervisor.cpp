// process_supervisor.cpp -- spawning process modules (clone + exec), their output, exits and
// restarts, and stopping them.  See process_supervisor.hpp for the contract.
#include "hosts/process_supervisor.hpp"

#include <fcntl.h>
#include <linux/futex.h>
#include <sched.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <set>

extern char **environ;

namespace irp::hosts {
namespace {

constexpr int64_t kMs = 1'000'000;
constexpr int64_t kSecond = 1'000'000'000;
constexpr int64_t kMaxBackoffNs = 10 * kSecond;
constexpr int64_t kStableRunNs = 10 * kSecond;   // running this long resets the backoff
constexpr int kExitLayoutRefused = 78;           // libindurop: built against another layout
constexpr std::size_t kChildStack = 128 * 1024;
constexpr uint32_t kFinalDrainBytes = 1u << 20;  // what is read after an exit at most

int64_t now() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * kSecond + ts.tv_nsec;
}

void sleepNs(int64_t ns) {
    timespec ts{static_cast<time_t>(ns / kSecond), static_cast<long>(ns % kSecond)};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
    }
}

template <class T>
std::atomic_ref<T> atomic(T &word) {
    return std::atomic_ref<T>(word);
}

void wakeAll(uint32_t *word) { syscall(SYS_futex, word, FUTEX_WAKE, INT32_MAX, nullptr, nullptr, 0); }

std::string describeStatus(int status) {
    if (WIFEXITED(status)) return "exited with status " + std::to_string(WEXITSTATUS(status));
    if (WIFSIGNALED(status)) {
        const int sig = WTERMSIG(status);
        const char *abbrev = sigabbrev_np(sig);
        const char *descr = sigdescr_np(sig);
        std::string s = "killed by " + (abbrev ? "SIG" + std::string(abbrev) : "signal " + std::to_string(sig));
        if (descr) s += std::string(" (") + descr + ")";
        if (WCOREDUMP(status)) s += ", core dumped";
        return s;
    }
    return "ended with wait status " + std::to_string(status);
}

// ---- the child side of a spawn: runs in clone(CLONE_VM | CLONE_VFORK), so it may only make
// system calls on data prepared by the parent, and reports failures in the plan it shares.
struct SpawnPlan {
    const char *path = nullptr;
    char *const *argv = nullptr;
    char *const *envp = nullptr;
    const char *cwd = nullptr;
    int in_fd = -1, out_fd = -1, err_fd = -1;
    int rt_priority = 0;
    int cpu = -1;
    pid_t parent = 0;
    // written by the child
    const char *failed_step = nullptr;
    int failed_errno = 0;
    int sched_errno = 0;
    int cpu_errno = 0;
};

int installFd(int from, int to) {
    if (from == to) return fcntl(to, F_SETFD, 0);  // keep it across exec
    return dup2(from, to) < 0 ? -1 : 0;
}

[[noreturn]] void childFail(SpawnPlan *plan, const char *step) {
    plan->failed_step = step;
    plan->failed_errno = errno;
    _exit(127);
}

int childMain(void *arg) {
    auto *plan = static_cast<SpawnPlan *>(arg);
    // Default dispositions (irpd's handlers and SIG_IGN must not leak), the mask is cleared last:
    // the parent blocked every signal around clone().
    struct sigaction dfl{};
    dfl.sa_handler = SIG_DFL;
    sigemptyset(&dfl.sa_mask);
    for (int sig = 1; sig < NSIG; ++sig)
        if (sig != SIGKILL && sig != SIGSTOP) sigaction(sig, &dfl, nullptr);  // EINVAL for glibc's own: fine

    if (setpgid(0, 0) != 0) childFail(plan, "setpgid");
    if (prctl(PR_SET_PDEATHSIG, SIGKILL) != 0) childFail(plan, "prctl(PR_SET_PDEATHSIG)");
    if (getppid() != plan->parent) _exit(127);  // irpd died before the prctl: never run without it

    if (installFd(plan->in_fd, 0) || installFd(plan->out_fd, 1) || installFd(plan->err_fd, 2)) childFail(plan, "dup2");
    if (syscall(SYS_close_range, 3u, ~0u, 0u) != 0) {
        const long max = sysconf(_SC_OPEN_MAX);
        for (long fd = 3; fd < (max > 0 ? max : 65536); ++fd) close(static_cast<int>(fd));
    }
    if (chdir(plan->cwd) != 0) childFail(plan, "chdir");
    if (plan->cpu >= 0) {
        cpu_set_t set;
        CPU_ZERO(&set);
        CPU_SET(plan->cpu, &set);
        if (sched_setaffinity(0, sizeof set, &set) != 0) plan->cpu_errno = errno;
    }
    sched_param param{};
    if (plan->rt_priority > 0) {
        param.sched_priority = plan->rt_priority;
        if (sched_setscheduler(0, SCHED_FIFO, &param) != 0) {
            plan->sched_errno = errno;
            param.sched_priority = 0;
            sched_setscheduler(0, SCHED_OTHER, &param);
        }
    } else {
        sched_setscheduler(0, SCHED_OTHER, &param);  // never inherit the spawning thread's policy
    }
    // irpd's ambient capabilities (--user keeps CAP_SYS_NICE and CAP_IPC_LOCK ambient for its own
    // restart) must not reach the process: it runs with none.
    prctl(PR_CAP_AMBIENT, PR_CAP_AMBIENT_CLEAR_ALL, 0, 0, 0);
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    execve(plan->path, plan->argv, plan->envp);
    childFail(plan, "execve");
}

// A pipe whose ends are >= 3 (so that installing them as 0, 1, 2 cannot clobber one another),
// close-on-exec, the read end non-blocking.
bool makePipe(int &read_end, int &write_end) {
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0) return false;
    for (int &fd : fds)
        if (fd < 3) {
            int moved = fcntl(fd, F_DUPFD_CLOEXEC, 3);
            close(fd);
            fd = moved;
        }
    if (fds[0] < 0 || fds[1] < 0) {
        if (fds[0] >= 0) close(fds[0]);
        if (fds[1] >= 0) close(fds[1]);
        return false;
    }
    fcntl(fds[0], F_SETFL, fcntl(fds[0], F_GETFL) | O_NONBLOCK);
    read_end = fds[0];
    write_end = fds[1];
    return true;
}

// Splits the `args` property: white space separates, "..." groups (\" and \\ inside).
Result<std::vector<std::string>> splitArgs(const std::string &text) {
    std::vector<std::string> args;
    std::size_t i = 0;
    while (i < text.size()) {
        while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
        if (i == text.size()) break;
        std::string arg;
        while (i < text.size() && !std::isspace(static_cast<unsigned char>(text[i]))) {
            if (text[i] != '"') {
                arg += text[i++];
                continue;
            }
            const std::size_t open = i++;
            for (;;) {
                if (i == text.size())
                    return Error{"unterminated \" at character " + std::to_string(open + 1) + " of '" + text + "'"};
                if (text[i] == '"') {
                    ++i;
                    break;
                }
                if (text[i] == '\\' && i + 1 < text.size() && (text[i + 1] == '"' || text[i + 1] == '\\')) ++i;
                arg += text[i++];
            }
        }
        args.push_back(std::move(arg));
    }
    return args;
}

Result<int64_t> parseCount(const std::string &text, int64_t low, int64_t high) {
    if (text.empty() || text.size() > 12 || text.find_first_not_of("0123456789") != std::string::npos)
        return Error{"expected a whole number from " + std::to_string(low) + " to " + std::to_string(high) + ", got '" +
                     text + "'"};
    const int64_t v = std::stoll(text);
    if (v < low || v > high)
        return Error{"expected a whole number from " + std::to_string(low) + " to " + std::to_string(high) + ", got '" +
                     text + "'"};
    return v;
}

const std::set<std::string> kIrpdVariables = {"INDUROP_CTL", "INDUROP_SLOT", "INDUROP_SHM", "INDUROP_MODULE"};

} // namespace

const char *toString(RestartPolicy policy) {
    switch (policy) {
    case RestartPolicy::Never: return "never";
    case RestartPolicy::Always: return "always";
    case RestartPolicy::OnFailure: return "on-failure";
    }
    return "?";
}

struct ProcessSupervisor::Stream {
    int fd = -1;
    std::string partial;    // an unfinished line, at most max_line_bytes
    bool skipping = false;  // the current line was cut: skip up to its newline
};

struct ProcessSupervisor::Child {
    ProcessLaunch launch;
    RestartPolicy policy = RestartPolicy::OnFailure;
    int64_t first_delay_ns = 100 * kMs;
    int64_t max_restarts = -1;  // -1 = unlimited
    std::vector<std::string> args;
    std::vector<std::pair<std::string, std::string>> env;
    std::string exe, cwd;

    bool stopping = false;  // stopAll() is ending it: its exit is expected
    bool term_sent = false;
    int64_t started_ns = 0;
    int consecutive = 0;    // quick exits in a row (the backoff exponent)
    int64_t restart_due_ns = 0;
    bool sched_reported = false, cpu_reported = false;
    Stream out, err;

    // output rate window
    int64_t window_start_ns = 0;
    uint64_t window_lines = 0, window_bytes = 0;
    uint64_t window_dropped = 0, window_dropped_bytes = 0;

    ProcessInfo info;

    bool handshake() const { return launch.spec.operation != config::OperationType::NonReal && !launch.control_shm.empty(); }
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
    } catch (...) {
    }
    for (auto &c : children_) closeStreams(*c);
    if (devnull_ >= 0) close(devnull_);
}

void ProcessSupervisor::emit(std::string_view line) {
    try {
        sink_(line);
    } catch (...) {
        // a sink that throws loses the line, never the supervisor
    }
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

        auto child = std::make_unique<Child>();
        child->launch = launch;
        for (const auto &[name, value] : spec.properties) {
            if (name == "args") {
                auto args = splitArgs(value);
                if (!args) return Error{where + "property args: " + args.error().message};
                child->args = std::move(*args);
            } else if (name.starts_with("env.")) {
                const std::string var = name.substr(4);
                if (var.empty() || var.find('=') != std::string::npos)
                    return Error{where + "property " + name + ": not an environment variable name"};
                if (kIrpdVariables.count(var))
                    return Error{where + "property " + name + ": " + var + " is set by irpd and cannot be overridden"};
                child->env.emplace_back(var, value);
            } else if (name == "restart") {
                if (value == "never") child->policy = RestartPolicy::Never;
                else if (value == "always") child->policy = RestartPolicy::Always;
                else if (value == "on-failure") child->policy = RestartPolicy::OnFailure;
                else return Error{where + "property restart = '" + value + "': expected never, always or on-failure"};
            } else if (name == "restart_delay_ms") {
                auto ms = parseCount(value, 1, kMaxBackoffNs / kMs);
                if (!ms) return Error{where + "property restart_delay_ms: " + ms.error().message};
                child->first_delay_ns = *ms * kMs;
            } else if (name == "max_restarts") {
                if (value == "unlimited") {
                    child->max_restarts = -1;
                } else {
                    auto n = parseCount(value, 0, 1'000'000'000);
                    if (!n) return Error{where + "property max_restarts: " + n.error().message + " (or 'unlimited')"};
                    child->max_restarts = *n;
                }
            }
        }

        std::error_code ec;
        const std::filesystem::path exe = std::filesystem::absolute(spec.path, ec).lexically_normal();
        const std::string shown = "<filename> " + (spec.filename.empty() ? spec.path.string() : spec.filename) + " -> " +
                                  exe.string();
        if (!std::filesystem::exists(exe, ec)) return Error{where + shown + " does not exist"};
        if (!std::filesystem::is_regular_file(exe, ec)) return Error{where + shown + " is not a regular file"};
        if (access(exe.c_str(), X_OK) != 0)
            return Error{where + shown + " is not executable (" + std::strerror(errno) + "; chmod +x it)"};
        child->exe = exe.string();
        child->cwd = exe.parent_path().string();

        if (launch.rt_priority < 0 || launch.rt_priority > 99)
            return Error{where + "RT priority " + std::to_string(launch.rt_priority) + " is outside 0..99"};
        if (launch.cpu >= CPU_SETSIZE || launch.cpu < -1) return Error{where + "CPU " + std::to_string(launch.cpu) + " does not exist"};
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
    atomic(s->kind).store(static_cast<uint32_t>(child.launch.spec.operation), std::memory_order_relaxed);
    std::snprintf(s->name, sizeof s->name, "%s", child.launch.spec.name.c_str());
    atomic(s->generation).fetch_add(1, std::memory_order_relaxed);
    atomic(s->state).store(INDUROP_PROCESS_STARTING, std::memory_order_release);
}

Status ProcessSupervisor::spawn(Child &child) {
    resetSlot(child);

    // Everything the child needs, prepared here: it may not allocate.
    std::vector<std::string> env;
    std::set<std::string> replaced(kIrpdVariables);
    for (const auto &[name, value] : child.env) replaced.insert(name);
    for (char **e = environ; e && *e; ++e) {
        const std::string_view entry(*e);
        if (!replaced.count(std::string(entry.substr(0, entry.find('='))))) env.emplace_back(entry);
    }
    if (!child.launch.control_shm.empty()) {
        env.push_back("INDUROP_CTL=" + child.launch.control_shm);
        env.push_back("INDUROP_SLOT=" + std::to_string(child.launch.slot));
    }
    if (!child.launch.variables_shm.empty()) env.push_back("INDUROP_SHM=" + child.launch.variables_shm);
    env.push_back("INDUROP_MODULE=" + child.launch.spec.name);
    for (const auto &[name, value] : child.env) env.push_back(name + "=" + value);
    std::vector<std::string> argv_storage{child.exe};
    argv_storage.insert(argv_storage.end(), child.args.begin(), child.args.end());
    std::vector<char *> argv, envp;
    for (auto &a : argv_storage) argv.push_back(a.data());
    argv.push_back(nullptr);
    for (auto &e : env) envp.push_back(e.data());
    envp.push_back(nullptr);

    int out_r = -1, out_w = -1, err_r = -1, err_w = -1;
    if (!makePipe(out_r, out_w)) return Error{std::string("cannot create its stdout pipe: ") + std::strerror(errno)};
    if (!makePipe(err_r, err_w)) {
        const int e = errno;
        close(out_r), close(out_w);
        return Error{std::string("cannot create its stderr pipe: ") + std::strerror(e)};
    }

    SpawnPlan plan;
    plan.path = child.exe.c_str();
    plan.argv = argv.data();
    plan.envp = envp.data();
    plan.cwd = child.cwd.c_str();
    plan.in_fd = devnull_;
    plan.out_fd = out_w;
    plan.err_fd = err_w;
    plan.rt_priority = child.launch.rt_priority;
    plan.cpu = child.launch.cpu;
    plan.parent = getpid();

    void *stack = mmap(nullptr, kChildStack, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_STACK, -1, 0);
    pid_t pid = -1;
    int clone_errno = 0;
    if (stack != MAP_FAILED) {
        sigset_t all, old;
        sigfillset(&all);
        pthread_sigmask(SIG_SETMASK, &all, &old);
        pid = clone(childMain, static_cast<char *>(stack) + kChildStack, CLONE_VM | CLONE_VFORK | SIGCHLD, &plan);
        clone_errno = errno;
        pthread_sigmask(SIG_SETMASK, &old, nullptr);
        munmap(stack, kChildStack);
    } else {
        clone_errno = errno;
    }
    close(out_w);
    close(err_w);
    std::atomic_signal_fence(std::memory_order_seq_cst);  // the child wrote plan while we were suspended

    if (pid < 0 || plan.failed_step) {
        close(out_r), close(err_r);
        if (indurop_process_slot *s = slotOf(child)) atomic(s->state).store(INDUROP_PROCESS_EXITED, std::memory_order_release);
        if (pid < 0) return Error{std::string("cannot start ") + child.exe + ": clone: " + std::strerror(clone_errno)};
        int status = 0;
        while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
        }
        return Error{"cannot start " + child.exe + ": " + plan.failed_step + ": " + std::strerror(plan.failed_errno)};
    }

    child.out.fd = out_r;
    child.err.fd = err_r;
    child.out.partial.clear();
    child.err.partial.clear();
    child.out.skipping = child.err.skipping = false;
    child.stopping = false;
    child.term_sent = false;
    child.started_ns = now();
    child.info.pid = pid;
    child.info.running = true;
    child.info.restart_pending = false;
    if (indurop_process_slot *s = slotOf(child)) atomic(s->pid).store(pid, std::memory_order_release);

    if (plan.sched_errno && !child.sched_reported) {
        child.sched_reported = true;
        emit("irpd: " + child.who() + ": SCHED_FIFO priority " + std::to_string(plan.rt_priority) + " refused (" +
             std::strerror(plan.sched_errno) + "); it runs SCHED_OTHER, its periods are not real-time");
    }
    if (plan.cpu_errno && !child.cpu_reported) {
        child.cpu_reported = true;
        emit("irpd: " + child.who() + ": cannot pin it to CPU " + std::to_string(plan.cpu) + " (" +
             std::strerror(plan.cpu_errno) + "); it runs on any CPU");
    }
    return Ok{};
}

// ---- output ---------------------------------------------------------------------------------

void ProcessSupervisor::flushDropReport(Child &child, bool force) {
    const int64_t t = now();
    if (!force && t - child.window_start_ns < kSecond) return;
    if (child.window_dropped) {
        emit("irpd: " + child.who() + ": " + std::to_string(child.window_dropped) + " output lines (" +
             std::to_string(child.window_dropped_bytes) + " bytes) dropped: more than " +
             std::to_string(limits_.lines_per_second) + " lines or " + std::to_string(limits_.bytes_per_second / 1024) +
             " KiB per second");
    }
    child.window_start_ns = t;
    child.window_lines = child.window_bytes = 0;
    child.window_dropped = child.window_dropped_bytes = 0;
}

void ProcessSupervisor::deliver(Child &child, std::string_view line, bool cut) {
    if (now() - child.window_start_ns >= kSecond) flushDropReport(child, true);
    if (child.window_lines >= limits_.lines_per_second || child.window_bytes + line.size() > limits_.bytes_per_second) {
        ++child.window_dropped;
        child.window_dropped_bytes += line.size();
        ++child.info.dropped_lines;
        return;
    }
    ++child.window_lines;
    child.window_bytes += line.size();
    ++child.info.lines;
    std::string text;
    text.reserve(child.launch.spec.name.size() + line.size() + 32);
    text.append("[").append(child.launch.spec.name).append("] ").append(line);
    if (cut) text.append(" [line cut at ").append(std::to_string(limits_.max_line_bytes)).append(" bytes]");
    emit(text);
}

void ProcessSupervisor::readStream(Child &child, Stream &stream, bool final_drain) {
    if (stream.fd < 0) return;
    char buffer[16384];
    uint64_t budget = final_drain ? kFinalDrainBytes : limits_.read_bytes_per_poll;
    const std::size_t max_line = std::max<uint32_t>(limits_.max_line_bytes, 1);
    while (budget > 0) {
        const ssize_t n = ::read(stream.fd, buffer, std::min<uint64_t>(sizeof buffer, budget));
        if (n < 0 && errno == EINTR) continue;
        if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK)) {  // EOF or a dead pipe
            close(stream.fd);
            stream.fd = -1;
            break;
        }
        if (n < 0) break;  // nothing more for now
        budget -= static_cast<uint64_t>(n);
        std::string_view data(buffer, static_cast<std::size_t>(n));
        while (!data.empty()) {
            const std::size_t nl = data.find('\n');
            const std::size_t take = nl == std::string_view::npos ? data.size() : nl;
            if (stream.skipping) {
                if (nl == std::string_view::npos) break;
                stream.skipping = false;
                data.remove_prefix(nl + 1);
                continue;
            }
            const std::size_t room = max_line - stream.partial.size();
            if (take > room) {
                stream.partial.append(data.substr(0, room));
                deliver(child, stream.partial, true);
                stream.partial.clear();
                if (nl == std::string_view::npos) {
                    stream.skipping = true;
                    break;
                }
                data.remove_prefix(nl + 1);
                continue;
            }
            if (nl == std::string_view::npos) {
                stream.partial.append(data);
                break;
            }
            if (stream.partial.empty()) {
                deliver(child, data.substr(0, nl), false);
            } else {
                stream.partial.append(data.substr(0, nl));
                deliver(child, stream.partial, false);
                stream.partial.clear();
            }
            data.remove_prefix(nl + 1);
        }
    }
}

void ProcessSupervisor::readOutput(Child &child, bool final_drain) {
    readStream(child, child.out, final_drain);
    readStream(child, child.err, final_drain);
}

void ProcessSupervisor::closeStreams(Child &child) {
    for (Stream *s : {&child.out, &child.err}) {
        if (!s->partial.empty()) deliver(child, s->partial, false);  // a last line without newline
        s->partial.clear();
        s->skipping = false;
        if (s->fd >= 0) close(s->fd);
        s->fd = -1;
    }
}

// ---- exits and restarts -----------------------------------------------------------------------

void ProcessSupervisor::handleExit(Child &child, int status) {
    const pid_t pid = child.info.pid;
    readOutput(child, true);  // its last words come before the news of its end
    closeStreams(child);
    flushDropReport(child, true);

    const bool signaled = status >= 0 && WIFSIGNALED(status);
    const bool failed = status < 0 || signaled || WEXITSTATUS(status) != 0;
    child.info.running = false;
    child.info.pid = 0;
    ++child.info.exits;
    if (signaled && !child.stopping) ++child.info.crashes;
    if (status >= 0 && WIFEXITED(status) && WEXITSTATUS(status) != 0) ++child.info.failures;
    child.info.last_exit = status < 0 ? "ended (its exit status was lost: is SIGCHLD ignored?)" : describeStatus(status);
    if (indurop_process_slot *s = slotOf(child)) {
        atomic(s->pid).store(0, std::memory_order_relaxed);
        atomic(s->state).store(INDUROP_PROCESS_EXITED, std::memory_order_release);
        wakeAll(&s->state);
    }

    std::string line = "irpd: " + child.who() + " (pid " + std::to_string(pid) + ") " + child.info.last_exit;
    if (child.stopping) {
        emit(line);
        return;
    }
    const bool wanted = child.policy == RestartPolicy::Always || (child.policy == RestartPolicy::OnFailure && failed);
    if (status >= 0 && WIFEXITED(status) && WEXITSTATUS(status) == kExitLayoutRefused) {
        emit(line + "; not restarted: it refused the running shared-variable layout (rebuild it against the set's .glb files)");
    } else if (!wanted) {
        emit(line + "; not restarted (restart=" + toString(child.policy) + ")");
    } else if (child.max_restarts >= 0 && static_cast<int64_t>(child.info.restarts) >= child.max_restarts) {
        emit(line + "; not restarted: max_restarts " + std::to_string(child.max_restarts) + " reached");
    } else {
        if (now() - child.started_ns >= kStableRunNs) child.consecutive = 0;
        int64_t delay = child.first_delay_ns;
        for (int i = 0; i < child.consecutive && delay < kMaxBackoffNs; ++i) delay *= 2;
        delay = std::min(delay, kMaxBackoffNs);
        ++child.consecutive;
        child.restart_due_ns = now() + delay;
        child.info.restart_pending = true;
        emit(line + "; restarting in " + std::to_string(delay / kMs) + " ms (restart=" + toString(child.policy) + ")");
    }
}

void ProcessSupervisor::poll() {
    for (auto &c : children_) {
        Child &child = *c;
        try {
            if (child.info.running) {
                readOutput(child, false);
                if (child.window_dropped) flushDropReport(child, false);
                int status = 0;
                const pid_t r = waitpid(child.info.pid, &status, WNOHANG);
                if (r == child.info.pid) handleExit(child, status);
                else if (r < 0 && errno == ECHILD) handleExit(child, -1);
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
                    int64_t delay = child.first_delay_ns;
                    for (int i = 0; i < child.consecutive && delay < kMaxBackoffNs; ++i) delay *= 2;
                    delay = std::min(delay, kMaxBackoffNs);
                    ++child.consecutive;
                    const bool again = child.max_restarts < 0 || static_cast<int64_t>(child.info.restarts) < child.max_restarts;
                    child.info.restart_pending = again;
                    child.restart_due_ns = now() + delay;
                    emit("irpd: " + child.who() + ": restart failed: " + s.error().message +
                         (again ? "; next try in " + std::to_string(delay / kMs) + " ms" : "; max_restarts reached"));
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
            if (!child.info.running)
                return Error{child.who() + " is not running (" + child.info.last_exit + ")"};
            indurop_process_slot *s = slotOf(child);
            const uint32_t state = s ? atomic(s->state).load(std::memory_order_acquire) : uint32_t{INDUROP_PROCESS_READY};
            if (state != INDUROP_PROCESS_READY && state != INDUROP_PROCESS_RUNNING)
                slow += (slow.empty() ? "'" : ", '") + child.launch.spec.name + "' (pid " + std::to_string(child.info.pid) + ")";
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
    auto chosen = [&slots](const Child &c) { return std::find(slots.begin(), slots.end(), c.launch.slot) != slots.end(); };
    stopWhere(chosen, grace_ns);
    std::erase_if(children_, [&](const std::unique_ptr<Child> &c) { return chosen(*c); });
}

void ProcessSupervisor::stopWhere(const std::function<bool(const Child &)> &chosen, int64_t grace_ns, bool term_non_real) {
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
            wakeAll(&s->release_seq);
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
                readOutput(child, false);
            } catch (...) {
            }
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
            if (indurop_process_slot *s = slotOf(child)) wakeAll(&s->release_seq);
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
                    emit("irpd: " + c->who() + " (pid " + std::to_string(c->info.pid) + ") survives SIGKILL; left behind");
                    closeStreams(*c);
                    c->info.running = false;
                }
            break;
        }
        sleepNs(5 * kMs);
    }
}

std::vector<ProcessInfo> ProcessSupervisor::processes() const {
    std::vector<ProcessInfo> all;
    for (const auto &c : children_) all.push_back(c->info);
    return all;
}

std::optional<ProcessInfo> ProcessSupervisor::process(const std::string &name) const {
    std::optional<ProcessInfo> found;  // the latest of that name (a replacement comes after the original)
    for (const auto &c : children_)
        if (c->launch.spec.name == name) found = c->info;
    return found;
}

} // namespace irp::hosts
