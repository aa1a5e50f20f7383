// process_spawn.cpp -- clone + exec of one child process, its pipes and its environment; see
// process_spawn.hpp.
#include "hosts/process_spawn.hpp"

#include "config/process_properties.hpp"

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <set>

namespace irp::hosts {
namespace {

constexpr std::size_t kChildStack = 128 * 1024;

// ---- the child side: runs in clone(CLONE_VM | CLONE_VFORK), so it may only make system calls on
// data prepared by the parent, and reports failures in the plan it shares.
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
    struct sigaction dfl {};
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

}  // namespace

std::vector<std::string> childEnvironment(char *const *base,
                                          const std::vector<std::pair<std::string, std::string>> &set) {
    std::set<std::string, std::less<>> replaced;
    for (const auto &[name, value] : set) replaced.insert(name);
    std::vector<std::string> env;
    for (char *const *e = base; e && *e; ++e) {
        const std::string_view entry(*e);
        const std::string_view name = entry.substr(0, entry.find('='));
        if (!config::isIrpdVariable(name) && !replaced.count(name)) env.emplace_back(entry);
    }
    for (const auto &[name, value] : set) env.push_back(name + "=" + value);
    return env;
}

std::string describeWaitStatus(int status) {
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

Result<Spawned> spawnChild(const SpawnRequest &request) {
    // Everything the child needs, prepared here: it may not allocate.
    std::vector<std::string> argv_storage{request.exe};
    argv_storage.insert(argv_storage.end(), request.args.begin(), request.args.end());
    std::vector<std::string> env_storage = request.env;
    std::vector<char *> argv, envp;
    for (auto &a : argv_storage) argv.push_back(a.data());
    argv.push_back(nullptr);
    for (auto &e : env_storage) envp.push_back(e.data());
    envp.push_back(nullptr);

    int out_r = -1, out_w = -1, err_r = -1, err_w = -1;
    if (!makePipe(out_r, out_w)) return Error{std::string("cannot create its stdout pipe: ") + std::strerror(errno)};
    if (!makePipe(err_r, err_w)) {
        const int e = errno;
        close(out_r), close(out_w);
        return Error{std::string("cannot create its stderr pipe: ") + std::strerror(e)};
    }

    SpawnPlan plan;
    plan.path = request.exe.c_str();
    plan.argv = argv.data();
    plan.envp = envp.data();
    plan.cwd = request.cwd.c_str();
    plan.in_fd = request.stdin_fd;
    plan.out_fd = out_w;
    plan.err_fd = err_w;
    plan.rt_priority = request.rt_priority;
    plan.cpu = request.cpu;
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
        if (pid < 0) return Error{"cannot start " + request.exe + ": clone: " + std::strerror(clone_errno)};
        int status = 0;
        while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
        return Error{"cannot start " + request.exe + ": " + plan.failed_step + ": " + std::strerror(plan.failed_errno)};
    }
    Spawned spawned;
    spawned.pid = pid;
    spawned.out_fd = out_r;
    spawned.err_fd = err_r;
    spawned.sched_errno = plan.sched_errno;
    spawned.cpu_errno = plan.cpu_errno;
    return spawned;
}

}  // namespace irp::hosts
