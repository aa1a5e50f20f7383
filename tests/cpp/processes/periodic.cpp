// periodic.cpp -- a process module that tells what it sees: its arguments, environment and
// working directory, then one line per release with the cycle irp::cycle() reports.  Options
// (the `args` property) make it fail on purpose:
//   --env NAME        print NAME's value at start (repeatable)
//   --no-init         never call irp::initPeriodExe(); sleep until killed
//   --exit-now N      exit with status N at once (before initPeriodExe)
//   --crash-at K      raise SIGSEGV in its K-th period
//   --exit-at K N     exit with status N in its K-th period
//   --hang-at K       ignore SIGTERM and never finish its K-th period
//   --flood-at K N    print N lines as fast as it can in its K-th period
#include <indurop/indurop.h>

#include <dirent.h>
#include <sched.h>
#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

int main(int argc, char *argv[]) {
    setvbuf(stdout, nullptr, _IOLBF, 0);
    long crash_at = -1, exit_at = -1, exit_status = 0, hang_at = -1, flood_at = -1, flood_lines = 0;
    bool init = true;
    std::vector<std::string> env;
    std::printf("start pid=%d argc=%d\n", static_cast<int>(getpid()), argc);
    for (int i = 1; i < argc; ++i) std::printf("arg[%d]=%s\n", i, argv[i]);
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> long { return i + 1 < argc ? std::atol(argv[++i]) : 0; };
        if (a == "--env" && i + 1 < argc)
            env.push_back(argv[++i]);
        else if (a == "--no-init")
            init = false;
        else if (a == "--exit-now")
            return static_cast<int>(next());
        else if (a == "--crash-at")
            crash_at = next();
        else if (a == "--exit-at")
            exit_at = next(), exit_status = next();
        else if (a == "--hang-at")
            hang_at = next();
        else if (a == "--flood-at")
            flood_at = next(), flood_lines = next();
    }
    for (const std::string &name : env) {
        const char *value = std::getenv(name.c_str());
        std::printf("env %s=%s\n", name.c_str(), value ? value : "(unset)");
    }
    char cwd[4096] = "";
    if (getcwd(cwd, sizeof cwd)) std::printf("cwd=%s\n", cwd);
    std::printf("stdin=%s\n", isatty(0) ? "tty" : "not a tty");
    std::printf("pgrp=%s\n", getpgrp() == getpid() ? "own" : "inherited");
    sched_param param{};
    sched_getparam(0, &param);
    const int policy = sched_getscheduler(0);
    std::printf("sched=%s prio=%d\n",
                policy == SCHED_FIFO    ? "FIFO"
                : policy == SCHED_OTHER ? "OTHER"
                                        : "other",
                param.sched_priority);
    cpu_set_t cpus;
    if (sched_getaffinity(0, sizeof cpus, &cpus) == 0) {
        std::string list;
        for (int c = 0; c < CPU_SETSIZE; ++c)
            if (CPU_ISSET(c, &cpus)) list += (list.empty() ? "" : ",") + std::to_string(c);
        std::printf("cpus=%s\n", list.c_str());
    }
    if (DIR *d = opendir("/proc/self/fd")) {
        std::string fds;
        while (dirent *e = readdir(d))
            if (e->d_name[0] != '.' && std::atoi(e->d_name) != dirfd(d))
                fds += (fds.empty() ? "" : ",") + std::string(e->d_name);
        closedir(d);
        std::printf("fds=%s\n", fds.c_str());
    }

    if (!init) {
        for (;;) pause();
    }
    if (irp::initPeriodExe() != 0) {
        std::printf("init failed\n");
        return 2;
    }
    std::printf("ready\n");
    for (long n = 1;; ++n) {
        if (irp::waitPeriod() != 0) {
            std::printf("stop requested after %ld periods\n", n - 1);
            return 0;
        }
        const irp::Cycle &c = irp::cycle();
        std::printf("period n=%ld cycle=%llu slot=%u planned=%lld basic=%lld\n", n,
                    static_cast<unsigned long long>(c.count), c.slot, static_cast<long long>(c.planned_ns),
                    static_cast<long long>(c.basic_ns));
        if (n == crash_at) raise(SIGSEGV);
        if (n == flood_at)
            for (long i = 0; i < flood_lines; ++i) std::printf("flood line %ld\n", i);
        if (n == exit_at) return static_cast<int>(exit_status);
        if (n == hang_at) {
            signal(SIGTERM, SIG_IGN);
            std::printf("hanging\n");
            for (;;) pause();
        }
    }
}
