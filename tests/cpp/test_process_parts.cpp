// test_process_parts.cpp -- the process supervisor's parts on their own, without a control
// segment: the restart policy's decisions and backoff (no clock), the output limits (a pipe and a
// fake clock), the child's environment, one real spawn of /bin/sh, and the dispatcher's wait for a
// done word that the watchdog bounds.
#include "config/process_properties.hpp"
#include "dispatch/watchdog.hpp"
#include "hosts/process_output.hpp"
#include "hosts/process_spawn.hpp"
#include "hosts/restart_policy.hpp"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

using namespace irp;
using hosts::RestartPolicy;

namespace {

constexpr int64_t kMs = 1'000'000;
constexpr int64_t kSecond = 1'000'000'000;

int exitedWith(int code) { return W_EXITCODE(code, 0); }
int killedBy(int sig) { return W_EXITCODE(0, sig); }

RestartPolicy policy(config::RestartPolicy restart, int64_t delay_ms = 100, int64_t max_restarts = -1) {
    config::ProcessProperties p;
    p.restart = restart;
    p.restart_delay_ns = delay_ms * kMs;
    p.max_restarts = max_restarts;
    return RestartPolicy(p);
}

}  // namespace

// ---- restart policy ---------------------------------------------------------------------------

TEST(RestartPolicy, OnFailureRestartsACrashAndAFailureButNotACleanExit) {
    RestartPolicy p = policy(config::RestartPolicy::OnFailure);
    auto crash = p.afterExit(killedBy(SIGSEGV), kMs, 0);
    EXPECT_TRUE(crash.restart);
    EXPECT_EQ(crash.delay_ns, 100 * kMs);
    EXPECT_EQ(crash.why, "; restarting in 100 ms (restart=on-failure)");
    EXPECT_TRUE(p.afterExit(exitedWith(3), kMs, 1).restart);
    EXPECT_TRUE(p.afterExit(-1, kMs, 2).restart);  // a lost status counts as a failure
    auto clean = p.afterExit(exitedWith(0), kMs, 3);
    EXPECT_FALSE(clean.restart);
    EXPECT_EQ(clean.why, "; not restarted (restart=on-failure)");
}

TEST(RestartPolicy, NeverAndAlways) {
    RestartPolicy never = policy(config::RestartPolicy::Never);
    auto crash = never.afterExit(killedBy(SIGKILL), kMs, 0);
    EXPECT_FALSE(crash.restart);
    EXPECT_EQ(crash.why, "; not restarted (restart=never)");
    RestartPolicy always = policy(config::RestartPolicy::Always);
    EXPECT_TRUE(always.afterExit(exitedWith(0), kMs, 0).restart);
}

TEST(RestartPolicy, TheDelayDoublesPerQuickRestartUpToTenSecondsAndResetsAfterAStableRun) {
    RestartPolicy p = policy(config::RestartPolicy::Always, 1000);
    std::vector<int64_t> delays;
    for (int i = 0; i < 6; ++i) delays.push_back(p.afterExit(exitedWith(1), kMs, static_cast<uint64_t>(i)).delay_ns);
    EXPECT_EQ(delays,
              (std::vector<int64_t>{1 * kSecond, 2 * kSecond, 4 * kSecond, 8 * kSecond, 10 * kSecond, 10 * kSecond}));
    // A run of 10 s: the first delay again.
    EXPECT_EQ(p.afterExit(exitedWith(1), 10 * kSecond, 6).delay_ns, 1 * kSecond);
    EXPECT_EQ(p.afterExit(exitedWith(1), kMs, 7).delay_ns, 2 * kSecond);
}

TEST(RestartPolicy, MaxRestartsIsCountedByTheSupervisor) {
    RestartPolicy p = policy(config::RestartPolicy::Always, 1, 2);
    EXPECT_TRUE(p.afterExit(exitedWith(0), kMs, 0).restart);
    EXPECT_TRUE(p.afterExit(exitedWith(0), kMs, 1).restart);
    auto third = p.afterExit(exitedWith(0), kMs, 2);
    EXPECT_FALSE(third.restart);
    EXPECT_EQ(third.why, "; not restarted: max_restarts 2 reached");
    RestartPolicy none = policy(config::RestartPolicy::Always, 1, 0);
    EXPECT_FALSE(none.afterExit(killedBy(SIGSEGV), kMs, 0).restart);
}

TEST(RestartPolicy, AProcessThatRefusedTheLayoutIsNeverRestarted) {
    RestartPolicy p = policy(config::RestartPolicy::Always);
    auto refused = p.afterExit(exitedWith(hosts::kExitLayoutRefused), kMs, 0);
    EXPECT_FALSE(refused.restart);
    EXPECT_NE(refused.why.find("refused the running shared-variable layout"), std::string::npos) << refused.why;
}

TEST(RestartPolicy, AFailedStartTriesAgainWithTheBackoffUntilMaxRestarts) {
    RestartPolicy p = policy(config::RestartPolicy::OnFailure, 20, 2);
    auto first = p.afterFailedStart(1);
    EXPECT_TRUE(first.restart);
    EXPECT_EQ(first.delay_ns, 20 * kMs);
    EXPECT_EQ(first.why, "; next try in 20 ms");
    auto second = p.afterFailedStart(2);
    EXPECT_FALSE(second.restart);
    EXPECT_EQ(second.why, "; max_restarts reached");
}

// ---- output limits ------------------------------------------------------------------------------

namespace {

struct Piped {
    int read_end = -1, write_end = -1;
    Piped() {
        int fds[2];
        EXPECT_EQ(pipe2(fds, O_CLOEXEC | O_NONBLOCK), 0);
        read_end = fds[0];
        write_end = fds[1];
    }
    ~Piped() {
        if (write_end >= 0) close(write_end);
    }
    void write(const std::string &text) {
        ASSERT_EQ(::write(write_end, text.data(), text.size()), static_cast<ssize_t>(text.size()));
    }
    void closeWriter() {
        close(write_end);
        write_end = -1;
    }
};

struct Output {
    std::vector<std::string> lines;
    int64_t t = 5 * kSecond;
    Piped out, err;
    hosts::ProcessOutput output;
    explicit Output(hosts::OutputLimits limits = {})
        : output(
              "talker", limits, [this](std::string_view l) { lines.emplace_back(l); }, [this] { return t; }) {
        output.attach(out.read_end, err.read_end);
    }
};

}  // namespace

TEST(ProcessOutput, LinesOfBothStreamsAreForwardedWithTheModulesName) {
    Output o;
    o.out.write("first\nsecond\npart");
    o.err.write("oops\n");
    o.output.read();
    EXPECT_EQ(o.lines, (std::vector<std::string>{"[talker] first", "[talker] second", "[talker] oops"}));
    o.out.write("ial\n");
    o.output.read();
    EXPECT_EQ(o.lines.back(), "[talker] partial");
    o.out.write("no newline at the end");
    o.output.read();
    o.output.close();  // the last words
    EXPECT_EQ(o.lines.back(), "[talker] no newline at the end");
    EXPECT_EQ(o.output.lines(), 5u);
}

TEST(ProcessOutput, ALongLineIsCutAndItsRestSkipped) {
    hosts::OutputLimits limits;
    limits.max_line_bytes = 8;
    Output o(limits);
    o.out.write("0123456789abcdef\nshort\n");
    o.output.read();
    EXPECT_EQ(o.lines, (std::vector<std::string>{"[talker] 01234567 [line cut at 8 bytes]", "[talker] short"}));
}

TEST(ProcessOutput, AFloodIsDroppedCountedAndReportedOncePerSecond) {
    hosts::OutputLimits limits;
    limits.lines_per_second = 3;
    Output o(limits);
    o.out.write("a\nb\nc\nd\ne\n");
    o.output.read();
    EXPECT_EQ(o.lines, (std::vector<std::string>{"[talker] a", "[talker] b", "[talker] c"}));
    EXPECT_TRUE(o.output.dropping());
    EXPECT_EQ(o.output.droppedLines(), 2u);
    o.output.reportDrops(false);  // the window has not ended: nothing yet
    EXPECT_EQ(o.lines.size(), 3u);
    o.t += kSecond;
    o.output.reportDrops(false);
    ASSERT_EQ(o.lines.size(), 4u);
    EXPECT_EQ(
        o.lines.back(),
        "irpd: process module 'talker': 2 output lines (2 bytes) dropped: more than 3 lines or 64 KiB per second");
    EXPECT_FALSE(o.output.dropping());
    o.out.write("f\n");  // a new window
    o.output.read();
    EXPECT_EQ(o.lines.back(), "[talker] f");
}

TEST(ProcessOutput, TheByteLimitDropsToo) {
    hosts::OutputLimits limits;
    limits.bytes_per_second = 10;
    Output o(limits);
    o.out.write("12345678\n90\nx\n");
    o.output.read();
    EXPECT_EQ(o.lines, (std::vector<std::string>{"[talker] 12345678", "[talker] 90"}));
    EXPECT_EQ(o.output.droppedLines(), 1u);
}

// ---- the child's environment and a real spawn --------------------------------------------------

namespace {
// /dev/null on a descriptor >= 3, as the supervisor keeps it for its children's stdin.
int devNull() {
    const int fd = open("/dev/null", O_RDONLY | O_CLOEXEC);
    const int moved = fcntl(fd, F_DUPFD_CLOEXEC, 3);
    close(fd);
    return moved;
}
}  // namespace

TEST(ProcessSpawn, TheEnvironmentDropsIrpdsVariablesAndReplacesWhatIsSet) {
    std::string path = "PATH=/usr/bin", stale = "INDUROP_SHM=/old", foo = "FOO=old", bare = "BARE";
    char *base[] = {path.data(), stale.data(), foo.data(), bare.data(), nullptr};
    EXPECT_EQ(hosts::childEnvironment(base, {{"INDUROP_CTL", "/indurop.x.ctl"}, {"FOO", "new"}}),
              (std::vector<std::string>{"PATH=/usr/bin", "BARE", "INDUROP_CTL=/indurop.x.ctl", "FOO=new"}));
}

TEST(ProcessSpawn, WaitStatusesInWords) {
    EXPECT_EQ(hosts::describeWaitStatus(exitedWith(3)), "exited with status 3");
    EXPECT_EQ(hosts::describeWaitStatus(killedBy(SIGSEGV)).rfind("killed by SIGSEGV (", 0), 0u);
}

TEST(ProcessSpawn, AChildGetsItsArgumentsEnvironmentAndPipes) {
    const int in = devNull();
    hosts::SpawnRequest r;
    r.exe = "/bin/sh";
    r.cwd = "/";
    r.args = {"-c", "echo \"$0 $1 $GREETING $(pwd)\"; echo to-stderr >&2; exit 3", "zero", "one"};
    r.env = {"GREETING=hello"};
    r.stdin_fd = in;
    auto spawned = hosts::spawnChild(r);
    ASSERT_TRUE(spawned.ok()) << spawned.error().message;
    int status = 0;
    ASSERT_EQ(waitpid(spawned->pid, &status, 0), spawned->pid);
    EXPECT_EQ(hosts::describeWaitStatus(status), "exited with status 3");
    std::vector<std::string> lines;
    hosts::ProcessOutput output("sh", {}, [&](std::string_view l) { lines.emplace_back(l); });
    output.attach(spawned->out_fd, spawned->err_fd);
    output.read(true);
    output.close();
    EXPECT_EQ(lines, (std::vector<std::string>{"[sh] zero one hello /", "[sh] to-stderr"}));
    close(in);
}

TEST(ProcessSpawn, AMissingProgramIsAnErrorAndLeavesNothingBehind) {
    hosts::SpawnRequest r;
    r.exe = "/nonexistent/program";
    r.cwd = "/";
    r.stdin_fd = devNull();
    auto spawned = hosts::spawnChild(r);
    close(r.stdin_fd);
    ASSERT_FALSE(spawned.ok());
    EXPECT_EQ(spawned.error().message, "cannot start /nonexistent/program: execve: No such file or directory");
    EXPECT_EQ(waitpid(-1, nullptr, WNOHANG), -1);  // reaped: no child left
}
