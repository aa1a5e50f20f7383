// test_supervision.cpp -- irpd under a supervisor, seen from outside: the test plays systemd (a
// datagram socket of its own as NOTIFY_SOCKET, WATCHDOG_USEC, WATCHDOG_PID) and checks READY=1,
// STOPPING=1, and that watchdog pings keep coming while every dispatcher runs and stop when one
// of them hangs in a module although irpd's main thread still answers (docs/supervision.md).
#include "support/control_client.hpp"
#include "support/irpd.hpp"
#include "support/subprocess.hpp"

#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <poll.h>
#include <pwd.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

using nlohmann::json;
using testing_support::Client;
using testing_support::kIrpd;
using testing_support::Process;
using testing_support::TempDir;
using testing_support::uniqueInstance;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

const fs::path kModules = FIXTURE_MODULES;

// The shared memory an irpd killed on purpose leaves behind.
void removeShm(const std::string &instance) {
    for (const auto &entry : fs::directory_iterator("/dev/shm"))
        if (entry.path().filename().string().rfind("indurop." + instance + ".", 0) == 0) fs::remove(entry.path());
}

std::string kFig1ForSupervision() { return testing_support::kFig1; }

// systemd's side of sd_notify: every datagram irpd sends, with its arrival time.
class FakeSystemd {
public:
    explicit FakeSystemd(const fs::path &path) : path_(path) {
        fd_ = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
        bound_ = bind(fd_, reinterpret_cast<sockaddr *>(&addr), sizeof addr) == 0;
        reader_ = std::thread([this] { read(); });
    }
    ~FakeSystemd() {
        stop_ = true;
        reader_.join();
        close(fd_);
    }
    bool bound() const { return bound_; }

    struct Message {
        Clock::time_point at;
        std::string text;
    };
    // Messages holding `line` (one of the newline-separated assignments).
    std::vector<Message> with(const std::string &line) const {
        std::lock_guard lock(mutex_);
        std::vector<Message> out;
        for (const Message &m : messages_)
            if (("\n" + m.text + "\n").find("\n" + line + "\n") != std::string::npos) out.push_back(m);
        return out;
    }
    bool waitFor(const std::string &line, std::size_t count, std::chrono::milliseconds limit) const {
        const auto end = Clock::now() + limit;
        while (Clock::now() < end) {
            if (with(line).size() >= count) return true;
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        return false;
    }
    std::string all() const {
        std::lock_guard lock(mutex_);
        std::string text;
        for (const Message &m : messages_) text += "[" + m.text + "] ";
        return text;
    }

private:
    void read() {
        while (!stop_) {
            pollfd p{fd_, POLLIN, 0};
            if (poll(&p, 1, 50) <= 0) continue;
            char buffer[4096];
            ssize_t n = recv(fd_, buffer, sizeof buffer, 0);
            if (n <= 0) continue;
            std::lock_guard lock(mutex_);
            messages_.push_back({Clock::now(), std::string(buffer, static_cast<std::size_t>(n))});
        }
    }
    fs::path path_;
    int fd_ = -1;
    bool bound_ = false;
    std::atomic<bool> stop_{false};
    mutable std::mutex mutex_;
    std::vector<Message> messages_;
    std::thread reader_;
};

std::string module(const std::string &name, const std::string &file, int64_t period_ns, int priority,
                   const std::string &extra) {
    return "  <module><name>" + name + "</name><filename>" + file +
           "</filename><moduletype>thread</moduletype><operationtype>periodic</operationtype><period>" +
           std::to_string(period_ns) + "</period><priority>" + std::to_string(priority) + "</priority>" + extra +
           "</module>\n";
}

std::string trigger(const fs::path &file) {
    return "<property><value name=\"trigger\">" + file.string() + "</value></property>";
}

// A set of two dispatchers in `folder`/module.xml: "healthy" on main (1 ms), "stall" on executor
// "side" (2 ms), which blocks in run() for good once the file `stall` exists in the folder.
void writeStallSet(const fs::path &folder) {
    fs::copy_file(kModules / "stall_on_trigger.so", folder / "stall.so");
    fs::copy_file(kModules / "crash_on_trigger.so", folder / "healthy.so");
    std::ofstream(folder / "module.xml") << "<root>\n  <executor><name>side</name></executor>\n"
                                         << module("healthy", "healthy.so", 1'000'000, 1, trigger(folder / "never"))
                                         << module("stall", "stall.so", 2'000'000, 2,
                                                   trigger(folder / "stall") + "<executor>side</executor>")
                                         << "</root>\n";
}

// irpd on the stall set, as systemd would start it.
struct SupervisedIrpd {
    TempDir dir;
    FakeSystemd systemd{dir.path / "notify"};
    std::string socket = (dir.path / "irpd.sock").string();
    std::string instance = uniqueInstance();
    std::unique_ptr<Process> irpd;

    // watchdog_usec 0: no WATCHDOG_USEC; watchdog_pid: "self" = irpd's own pid, else that text.
    explicit SupervisedIrpd(int64_t watchdog_usec, const std::string &watchdog_pid = "self") {
        writeStallSet(dir.path);
        const std::string notify = (dir.path / "notify").string();
        irpd = std::make_unique<Process>(
            std::vector<std::string>{kIrpd, "--config", (dir.path / "module.xml").string(), "--control-socket", socket,
                                     "--instance", instance, "--module-cache", (dir.path / "cache").string()},
            dir.path, [=] {
                setenv("NOTIFY_SOCKET", notify.c_str(), 1);
                if (watchdog_usec) setenv("WATCHDOG_USEC", std::to_string(watchdog_usec).c_str(), 1);
                const std::string pid = watchdog_pid == "self" ? std::to_string(getpid()) : watchdog_pid;
                setenv("WATCHDOG_PID", pid.c_str(), 1);
            });
    }
    ~SupervisedIrpd() {
        kill(irpd->pid(), SIGKILL);  // a dispatcher hung in a module cannot stop cleanly
        irpd->wait(std::chrono::seconds(10));
        removeShm(instance);
    }
    void stallTheSideDispatcher() { std::ofstream(dir.path / "stall") << "now\n"; }
};

// The main thread answers on the control socket.
bool mainThreadAnswers(const std::string &socket) {
    Client client(socket, 10);
    if (!client.connected() || client.readLine().empty()) return false;
    json answer = client.request({{"cmd", "status"}});
    return answer.value("ok", false);
}

}  // namespace

TEST(Supervision, ReadyThenWatchdogPingsWhileEveryDispatcherRuns) {
    SupervisedIrpd s(300'000);  // WatchdogSec=300ms: a ping every 150 ms or so
    ASSERT_TRUE(s.systemd.bound());
    ASSERT_TRUE(s.systemd.waitFor("READY=1", 1, std::chrono::seconds(30))) << s.irpd->err() << s.systemd.all();
    const auto ready = s.systemd.with("READY=1").front();
    EXPECT_NE(ready.text.find("STATUS=running "), std::string::npos) << ready.text;
    EXPECT_TRUE(s.systemd.waitFor("WATCHDOG=1", 6, std::chrono::seconds(20))) << s.irpd->err() << s.systemd.all();
    EXPECT_NE(s.irpd->err().find("systemd watchdog: 300 ms"), std::string::npos) << s.irpd->err();
}

TEST(Supervision, PingsStopWhenADispatcherHangsInAModuleWhileTheMainThreadLives) {
    SupervisedIrpd s(300'000);
    ASSERT_TRUE(s.systemd.waitFor("READY=1", 1, std::chrono::seconds(30))) << s.irpd->err();
    ASSERT_TRUE(s.systemd.waitFor("WATCHDOG=1", 3, std::chrono::seconds(20))) << s.systemd.all();
    s.stallTheSideDispatcher();
    // Once the side dispatcher is stuck, no ping comes again: wait for a gap of 2 s without
    // one (at most 20 s), then watch 2 s more.
    const auto end = Clock::now() + std::chrono::seconds(20);
    bool quiet = false;
    while (!quiet && Clock::now() < end) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        quiet = Clock::now() - s.systemd.with("WATCHDOG=1").back().at > std::chrono::seconds(2);
    }
    ASSERT_TRUE(quiet) << "pings went on after the stall: " << s.systemd.all();
    const std::size_t pings = s.systemd.with("WATCHDOG=1").size();
    EXPECT_TRUE(mainThreadAnswers(s.socket)) << s.irpd->err();
    std::this_thread::sleep_for(std::chrono::seconds(2));
    EXPECT_EQ(s.systemd.with("WATCHDOG=1").size(), pings) << s.systemd.all();
    EXPECT_TRUE(mainThreadAnswers(s.socket)) << s.irpd->err();
    EXPECT_EQ(s.irpd->wait(std::chrono::milliseconds(10)), -1) << "irpd itself must not exit: systemd kills it";
}

TEST(Supervision, AWatchdogMeantForAnotherProcessIsNotPinged) {
    SupervisedIrpd s(300'000, "1");  // WATCHDOG_PID of another process: not ours (sd_watchdog_enabled)
    ASSERT_TRUE(s.systemd.waitFor("READY=1", 1, std::chrono::seconds(30))) << s.irpd->err();
    std::this_thread::sleep_for(std::chrono::seconds(1));
    EXPECT_TRUE(s.systemd.with("WATCHDOG=1").empty()) << s.systemd.all();
}

TEST(Supervision, StoppingIsToldOnSigterm) {
    SupervisedIrpd s(0);
    ASSERT_TRUE(s.systemd.waitFor("READY=1", 1, std::chrono::seconds(30))) << s.irpd->err();
    kill(s.irpd->pid(), SIGTERM);
    EXPECT_EQ(s.irpd->wait(std::chrono::seconds(20)), 0) << s.irpd->err();
    EXPECT_TRUE(s.systemd.waitFor("STOPPING=1", 1, std::chrono::seconds(1))) << s.systemd.all();
    EXPECT_TRUE(s.systemd.with("WATCHDOG=1").empty()) << "no WATCHDOG_USEC, no pings: " << s.systemd.all();
}

TEST(Supervision, ReloadsAreAnsweredAndPingsGoOnAfterThem) {
    SupervisedIrpd s(300'000);
    ASSERT_TRUE(s.systemd.waitFor("READY=1", 1, std::chrono::seconds(30))) << s.irpd->err();
    Client client(s.socket, 60);
    ASSERT_FALSE(client.readLine().empty());
    json answer = client.request({{"cmd", "set_period"}, {"module", "healthy"}, {"period_ns", 2'000'000}});
    ASSERT_TRUE(answer.value("ok", false)) << answer.dump();
    // The main thread stretched the watchdog for the reload, then restored it.
    EXPECT_TRUE(s.systemd.waitFor("WATCHDOG_USEC=300000", 1, std::chrono::seconds(5))) << s.systemd.all();
    EXPECT_TRUE(s.systemd.waitFor(
        "STATUS=running " + (s.dir.path / "module.xml").string() + " (generation 2, 2 of 2 modules enabled, " +
            (s.irpd->err().find("NOT REAL-TIME") == std::string::npos ? "real-time" : "NOT real-time") + ")",
        1, std::chrono::seconds(5)))
        << s.systemd.all();
    const std::size_t pings = s.systemd.with("WATCHDOG=1").size();
    EXPECT_TRUE(s.systemd.waitFor("WATCHDOG=1", pings + 3, std::chrono::seconds(20))) << s.systemd.all();
}

// A managed restart is a reload to systemd: RELOADING=1 with the watchdog stretched, then the new
// image's READY=1 restoring the interval, and pings from the same pid go on.
TEST(Supervision, AManagedRestartIsAReloadAndPingsGoOnAfterIt) {
    SupervisedIrpd s(300'000);
    ASSERT_TRUE(s.systemd.waitFor("READY=1", 1, std::chrono::seconds(30))) << s.irpd->err();
    json asked;
    {
        Client client(s.socket, 60);
        ASSERT_FALSE(client.readLine().empty());
        asked =
            client.request({{"cmd", "restart"}, {"config", (s.dir.path / "module.xml").string()}, {"set_id", "again"}});
    }
    ASSERT_TRUE(asked.value("ok", false)) << asked.dump();
    ASSERT_TRUE(s.systemd.waitFor("READY=1", 2, std::chrono::seconds(30))) << s.irpd->err() << s.systemd.all();
    const auto reloading = s.systemd.with("RELOADING=1");
    ASSERT_EQ(reloading.size(), 1u) << s.systemd.all();
    EXPECT_NE(reloading[0].text.find("WATCHDOG_USEC=60300000"), std::string::npos) << reloading[0].text;
    EXPECT_NE(reloading[0].text.find("MONOTONIC_USEC="), std::string::npos) << reloading[0].text;
    const auto ready = s.systemd.with("READY=1").back();
    EXPECT_NE(ready.text.find("WATCHDOG_USEC=300000"), std::string::npos) << ready.text;
    EXPECT_TRUE(s.systemd.with("STOPPING=1").empty()) << "a restart is no stop: " << s.systemd.all();
    const std::size_t pings = s.systemd.with("WATCHDOG=1").size();
    EXPECT_TRUE(s.systemd.waitFor("WATCHDOG=1", pings + 3, std::chrono::seconds(20))) << s.systemd.all();
    EXPECT_EQ(s.irpd->wait(std::chrono::milliseconds(1)), -1) << "the same process: " << s.irpd->err();
}

// ---- privilege drop (--user) ----------------------------------------------------------------

namespace {

std::string statusField(pid_t pid, const std::string &field) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/status");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind(field + ":", 0) == 0) {
            std::string value = line.substr(field.size() + 1);
            value.erase(0, value.find_first_not_of(" \t"));
            value.erase(value.find_last_not_of(" \t") + 1);
            return value;
        }
    return "";
}

std::vector<pid_t> childrenOf(pid_t pid) {
    std::vector<pid_t> out;
    for (const auto &task : fs::directory_iterator("/proc/" + std::to_string(pid) + "/task")) {
        std::ifstream in(task.path() / "children");
        pid_t child;
        while (in >> child) out.push_back(child);
    }
    return out;
}

int fifoThreads(pid_t pid) {
    int n = 0;
    for (const auto &task : fs::directory_iterator("/proc/" + std::to_string(pid) + "/task"))
        if (sched_getscheduler(std::stoi(task.path().filename().string())) == SCHED_FIFO) ++n;
    return n;
}

bool canUseFifo() {
    sched_param p{};
    p.sched_priority = 1;
    pid_t child = fork();
    if (child == 0) _exit(sched_setscheduler(0, SCHED_FIFO, &p) == 0 ? 0 : 1);
    int status = 0;
    waitpid(child, &status, 0);
    return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

}  // namespace

TEST(PrivilegeDrop, RunsAsTheUserWithTwoCapabilitiesAndHotReloadsStillGetRealTime) {
    if (geteuid() != 0) GTEST_SKIP() << "irpd --user needs the test to run as root";
    const passwd *nobody = getpwnam("nobody");
    if (!nobody) GTEST_SKIP() << "no user 'nobody' on this machine";
    if (!canUseFifo()) GTEST_SKIP() << "this machine refuses SCHED_FIFO even to root";
    TempDir dir;
    fs::permissions(dir.path, fs::perms(0755));
    fs::create_directory(dir.path / "run");
    ASSERT_EQ(chown((dir.path / "run").c_str(), nobody->pw_uid, nobody->pw_gid), 0);
    fs::copy_file(kModules / "crash_on_trigger.so", dir.path / "healthy.so");
    std::ofstream(dir.path / "module.xml")
        << "<root>\n"
        << module("healthy", "healthy.so", 1'000'000, 1, trigger(dir.path / "never")) << "</root>\n";
    const std::string socket = (dir.path / "run" / "irpd.sock").string(), instance = uniqueInstance();
    Process irpd({kIrpd, "--config", (dir.path / "module.xml").string(), "--control-socket", socket, "--instance",
                  instance, "--state-dir", (dir.path / "state").string(), "--module-cache",
                  (dir.path / "run" / "cache").string(), "--user", "nobody"},
                 dir.path);
    ASSERT_TRUE(irpd.waitForErr("irpd: running")) << irpd.err();
    const std::string ids = std::to_string(nobody->pw_uid), gids = std::to_string(nobody->pw_gid);
    EXPECT_EQ(statusField(irpd.pid(), "Uid"), ids + "\t" + ids + "\t" + ids + "\t" + ids);
    EXPECT_EQ(statusField(irpd.pid(), "Gid"), gids + "\t" + gids + "\t" + gids + "\t" + gids);
    EXPECT_EQ(statusField(irpd.pid(), "Groups"), gids);
    const std::string kept = "0000000000804000";  // CAP_IPC_LOCK (14) and CAP_SYS_NICE (23)
    EXPECT_EQ(statusField(irpd.pid(), "CapEff"), kept);
    EXPECT_EQ(statusField(irpd.pid(), "CapPrm"), kept);
    EXPECT_EQ(statusField(irpd.pid(), "CapBnd"), kept);
    // Inheritable and ambient too, so that irpd's exec of itself (a managed restart) keeps them.
    EXPECT_EQ(statusField(irpd.pid(), "CapInh"), kept);
    EXPECT_EQ(statusField(irpd.pid(), "CapAmb"), kept);
    EXPECT_EQ(statusField(irpd.pid(), "NoNewPrivs"), "1");
    EXPECT_GE(fifoThreads(irpd.pid()), 1) << "the dispatcher started after the switch is SCHED_FIFO";

    // What the agent's group uses: shared memory and the control socket, the user's group, 0660.
    for (const fs::path &p : {fs::path("/dev/shm/indurop." + instance + ".stats"), fs::path(socket)}) {
        struct stat st {};
        ASSERT_EQ(stat(p.c_str(), &st), 0) << p;
        EXPECT_EQ(st.st_uid, nobody->pw_uid) << p;
        EXPECT_EQ(st.st_gid, nobody->pw_gid) << p;
        EXPECT_EQ(st.st_mode & 0777, 0660u) << p;
    }

    // A hot reload after the switch: a new process module, started with SCHED_FIFO.
    const std::string exe = std::string(FIXTURE_PROCESSES) + "/proc_periodic.exe";
    std::ofstream(dir.path / "more.xml")
        << "<root>\n"
        << module("healthy", "healthy.so", 1'000'000, 1, trigger(dir.path / "never"))
        << "  <module><name>p</name><filename>" << exe
        << "</filename><moduletype>process</moduletype><operationtype>periodic</operationtype>"
           "<period>2000000</period><priority>3</priority></module>\n</root>\n";
    Client client(socket, 60);
    ASSERT_TRUE(client.connected());
    ASSERT_FALSE(client.readLine().empty());
    json loaded = client.request({{"cmd", "load"}, {"config", (dir.path / "more.xml").string()}});
    ASSERT_TRUE(loaded.value("ok", false)) << loaded.dump() << irpd.err();
    const std::vector<pid_t> children = childrenOf(irpd.pid());
    ASSERT_EQ(children.size(), 1u);
    EXPECT_EQ(sched_getscheduler(children[0]), SCHED_FIFO) << irpd.err();
    EXPECT_EQ(statusField(children[0], "CapEff"), "0000000000000000") << "a process module runs with no capability";
    EXPECT_EQ(statusField(children[0], "CapAmb"), "0000000000000000");
    json period = client.request({{"cmd", "set_period"}, {"module", "healthy"}, {"period_ns", 2'000'000}});
    EXPECT_TRUE(period.value("ok", false)) << period.dump();
    json status = client.request({{"cmd", "status"}});
    EXPECT_EQ(status["result"]["realtime"], true) << status.dump();

    // A managed restart: the same process, still the user, with the two capabilities, real-time.
    json asked = client.request({{"cmd", "restart"}, {"config", (dir.path / "more.xml").string()}, {"set_id", "more"}});
    ASSERT_TRUE(asked.value("ok", false)) << asked.dump();
    json after;
    for (int i = 0; i < 1500 && !(after.is_object() && after["last_restart"].is_object()); ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        Client again(socket, 10);
        if (again.connected() && !again.readLine().empty()) after = again.request({{"cmd", "status"}})["result"];
    }
    ASSERT_TRUE(after.is_object() && after["last_restart"].is_object()) << irpd.err();
    EXPECT_EQ(after["last_restart"]["fell_back"], false) << after.dump() << irpd.err();
    EXPECT_EQ(after["pid"], irpd.pid());
    EXPECT_EQ(after["realtime"], true) << irpd.err();
    EXPECT_EQ(statusField(irpd.pid(), "Uid"), ids + "\t" + ids + "\t" + ids + "\t" + ids);
    EXPECT_EQ(statusField(irpd.pid(), "CapEff"), kept);
    EXPECT_EQ(statusField(irpd.pid(), "CapAmb"), kept);
    EXPECT_EQ(statusField(irpd.pid(), "NoNewPrivs"), "1");
    EXPECT_GE(fifoThreads(irpd.pid()), 1) << "the new image's dispatcher is SCHED_FIFO";
    if (fs::exists("/dev/cpu_dma_latency")) {  // held open across the exec: the user could not open it
        EXPECT_EQ(irpd.err().find("cpu_dma_latency not held"), std::string::npos) << irpd.err();
    }
    kill(irpd.pid(), SIGTERM);
    EXPECT_EQ(irpd.wait(std::chrono::seconds(20)), 0) << irpd.err();
    EXPECT_FALSE(fs::exists("/dev/shm/indurop." + instance + ".stats")) << "removed by the user that owns it";
}

TEST(PrivilegeDrop, AControlSocketFolderTheUserMayNotWriteIsRefusedWithItsName) {
    if (geteuid() != 0) GTEST_SKIP() << "irpd --user needs the test to run as root";
    if (!getpwnam("nobody")) GTEST_SKIP() << "no user 'nobody' on this machine";
    TempDir dir;  // root's, mode 0700
    Process irpd({kIrpd, "--config", kFig1ForSupervision(), "--instance", uniqueInstance(), "--state-dir",
                  (dir.path / "state").string(), "--control-socket", (dir.path / "irpd.sock").string(), "--user",
                  "nobody"},
                 dir.path);
    EXPECT_EQ(irpd.wait(std::chrono::seconds(30)), 1);
    EXPECT_NE(irpd.err().find("--user nobody may not create irpd.sock in " + dir.path.string()), std::string::npos)
        << irpd.err();
}

TEST(PrivilegeDrop, AnUnknownUserIsRefusedBeforeAnythingStarts) {
    TempDir dir;
    Process irpd({kIrpd, "--config", kFig1ForSupervision(), "--instance", uniqueInstance(), "--state-dir",
                  (dir.path / "state").string(), "--user", "no-such-user-here"},
                 dir.path);
    EXPECT_EQ(irpd.wait(std::chrono::seconds(30)), 1);
    EXPECT_NE(irpd.err().find("--user: no user 'no-such-user-here' on this system"), std::string::npos) << irpd.err();
}

// ---- crash record ---------------------------------------------------------------------------

namespace {

// systemd's watchdog sends SIGABRT from pid 1.  A command line to put before irpd's: irpd as the
// child of pid 1 of a new PID namespace (unshare, root only), which sends it SIGABRT once the
// file `go` exists and waits for it to die.
bool canBePid1() { return geteuid() == 0 && std::system("unshare --pid --fork true 2>/dev/null") == 0; }
std::vector<std::string> asPid1SendingSigabrt(const fs::path &go) {
    return {"unshare", "--pid",
            "--fork",  "sh",
            "-c",      "\"$@\" & p=$!; until [ -e '" + go.string() + "' ]; do sleep 0.02; done; kill -ABRT $p; wait $p",
            "sh"};
}

// irpd on a set with "healthy" on main and "crashy" on executor "side", which dereferences null
// once the file `crash` exists (crashy's file: `crashy_so`, a build of trigger.cpp); the state
// folder and instance outlive one run.
struct CrashCell {
    TempDir dir;
    std::string instance = uniqueInstance();
    std::string socket = (dir.path / "irpd.sock").string();
    fs::path state = dir.path / "state";
    int runs = 0;

    explicit CrashCell(const std::string &policy, const std::string &crashy_so = "crash_on_trigger.so") {
        fs::copy_file(kModules / crashy_so, dir.path / "crashy.so");
        fs::copy_file(kModules / "crash_on_trigger.so", dir.path / "healthy.so");
        std::ofstream(dir.path / "module.xml")
            << "<root>\n  <executor><name>side</name></executor>\n"
            << module("healthy", "healthy.so", 1'000'000, 1, trigger(dir.path / "never"))
            << module("crashy", "crashy.so", 2'000'000, 2,
                      trigger(dir.path / "crash") + "<executor>side</executor>" + policy)
            << "</root>\n";
    }
    // irpd, or `wrapper` followed by irpd's command line.
    std::unique_ptr<Process> start(std::vector<std::string> wrapper = {}) {
        const fs::path out = dir.path / ("run" + std::to_string(++runs));
        fs::create_directory(out);
        for (const std::string &arg :
             {kIrpd, std::string("--config"), (dir.path / "module.xml").string(), std::string("--control-socket"),
              socket, std::string("--instance"), instance, std::string("--state-dir"), state.string(),
              std::string("--module-cache"), (dir.path / "cache").string()})
            wrapper.push_back(arg);
        auto p = std::make_unique<Process>(wrapper, out, [] {
            rlimit none{0, 0};
            setrlimit(RLIMIT_CORE, &none);  // no core file for the crash this test causes
        });
        EXPECT_TRUE(p->waitForErr("irpd: running")) << p->err();
        return p;
    }
    void pull(bool armed) {
        if (armed)
            std::ofstream(dir.path / "crash") << "now\n";
        else
            fs::remove(dir.path / "crash");
    }
    json ask(const json &request) {
        Client client(socket, 60);
        EXPECT_FALSE(client.readLine().empty());
        return client.request(request);
    }
    json moduleNamed(const std::string &name) {
        const json modules = ask({{"cmd", "modules"}});
        for (const json &m : modules["result"])
            if (m["name"] == name) return m;
        return nullptr;
    }
    bool hasEvent(const std::string &kind, const std::string &module) {
        const json events = ask({{"cmd", "events"}});
        for (const json &e : events["result"]["events"])
            if (e["kind"] == kind && e["module"] == module) return true;
        return false;
    }
    // The first run: crashy segfaults once triggered; irpd dies of SIGSEGV.
    void crashOnce() {
        auto first = start();
        pull(true);
        EXPECT_EQ(first->wait(std::chrono::seconds(30)), -2) << first->err();
        EXPECT_EQ(first->termSignal(), SIGSEGV) << first->err();
    }
    std::string record() { return testing_support::readFile(state / (instance + ".crash")); }
    ~CrashCell() { removeShm(instance); }
};

}  // namespace

TEST(CrashRecord, ASegfaultInAThreadModuleIsRecordedWithModuleExecutorAndSignal) {
    CrashCell cell("");
    cell.crashOnce();
    const std::string record = cell.record();
    EXPECT_NE(record.find("\nmodule=crashy\n"), std::string::npos) << record;
    EXPECT_NE(record.find("\nexecutor=side\n"), std::string::npos) << record;
    EXPECT_NE(record.find("\nsignal_name=SIGSEGV\n"), std::string::npos) << record;
    EXPECT_NE(record.find("\nset=" + fs::weakly_canonical(cell.dir.path / "module.xml").string() + "\n"),
              std::string::npos)
        << record;
    EXPECT_NE(record.find("\ngeneration=1\n"), std::string::npos) << record;
}

// The line of trigger.cpp that dereferences null, 1-based.
int crashLine() {
    std::ifstream source(std::string(SOURCE_ROOT) + "/tests/cpp/modules/trigger.cpp");
    int number = 0;
    for (std::string line; std::getline(source, line);) {
        ++number;
        if (line.find("*nowhere = 1;  // the crash line") != std::string::npos) return number;
    }
    return -1;
}

// The record names the faulting instruction (its module and its offset there); the next start
// maps it to the source line through the module's line table: the record, status and the event.
TEST(CrashRecord, TheRecordNamesTheSourceLineOfTheFaultingInstruction) {
    CrashCell cell("");
    cell.crashOnce();
    const std::string record = cell.record();
    EXPECT_NE(record.find("\ncode_module=crashy\n"), std::string::npos) << record;
    EXPECT_NE(record.find("\ncode_offset=0x"), std::string::npos) << record;
    EXPECT_NE(record.find("\npc=0x"), std::string::npos) << record;
    auto second = cell.start();
    const std::string where = "trigger.cpp:" + std::to_string(crashLine());
    json crash = cell.ask({{"cmd", "status"}})["result"]["last_crash"];
    EXPECT_EQ(crash["source"], where) << crash.dump();
    EXPECT_EQ(crash["code_module"], "crashy") << crash.dump();
    const json events = cell.ask({{"cmd", "events"}})["result"]["events"];
    bool named = false;
    for (const json &e : events)
        named |= e["kind"] == "crash" && e["message"].get<std::string>().find(where) != std::string::npos;
    EXPECT_TRUE(named) << events.dump();
    EXPECT_NE(second->err().find(where), std::string::npos) << second->err();
    // Kept with the record: a later start (no new crash) still says where.
    kill(second->pid(), SIGTERM);
    ASSERT_EQ(second->wait(std::chrono::seconds(20)), 0) << second->err();
    auto third = cell.start();
    EXPECT_EQ(cell.ask({{"cmd", "status"}})["result"]["last_crash"]["source"], where);
    kill(third->pid(), SIGTERM);
    EXPECT_EQ(third->wait(std::chrono::seconds(20)), 0) << third->err();
}

// Generated Structured Text carries `#line 12 "main.st"`: the record names the ST line.
TEST(CrashRecord, ALineDirectiveInTheModulesSourceMakesTheRecordNameThatLine) {
    CrashCell cell("", "crash_st_line.so");
    cell.crashOnce();
    auto second = cell.start();
    json crash = cell.ask({{"cmd", "status"}})["result"]["last_crash"];
    EXPECT_EQ(crash["source"], "main.st:12") << crash.dump();
    EXPECT_EQ(crash["module"], "crashy") << crash.dump();
}

// A module without a line table (stripped): the record still names the module and the offset.
TEST(CrashRecord, AStrippedModuleIsNamedWithItsOffsetAndNoSource) {
    CrashCell cell("");
    ASSERT_EQ(std::system(("strip --strip-debug " + (cell.dir.path / "crashy.so").string()).c_str()), 0);
    cell.crashOnce();
    auto second = cell.start();
    json crash = cell.ask({{"cmd", "status"}})["result"]["last_crash"];
    EXPECT_TRUE(crash["source"].is_null()) << crash.dump();
    EXPECT_EQ(crash["code_module"], "crashy") << crash.dump();
    EXPECT_TRUE(crash["code_offset"].is_string()) << crash.dump();
    EXPECT_NE(second->err().find("no source line known"), std::string::npos) << second->err();
}

TEST(CrashRecord, AFaultHasNoSenderAndCauseFault) {
    CrashCell cell("");
    cell.crashOnce();
    EXPECT_EQ(cell.record().find("\nsender_pid="), std::string::npos) << cell.record();
    cell.pull(false);
    auto second = cell.start();
    json crash = cell.ask({{"cmd", "status"}})["result"]["last_crash"];
    EXPECT_EQ(crash["cause"], "fault") << crash.dump();
    EXPECT_TRUE(crash["sender_pid"].is_null()) << crash.dump();
}

TEST(CrashRecord, ASignalSentToIrpdNamesItsSender) {
    CrashCell cell("");
    auto first = cell.start();
    kill(first->pid(), SIGABRT);
    EXPECT_EQ(first->wait(std::chrono::seconds(30)), -2) << first->err();
    EXPECT_EQ(first->termSignal(), SIGABRT);
    EXPECT_NE(cell.record().find("\nsender_pid=" + std::to_string(getpid()) + "\n"), std::string::npos)
        << cell.record();
    auto second = cell.start();
    json crash = cell.ask({{"cmd", "status"}})["result"]["last_crash"];
    EXPECT_EQ(crash["cause"], "signal") << crash.dump();
    EXPECT_EQ(crash["sender_pid"], getpid()) << crash.dump();
    EXPECT_TRUE(crash["module"].is_null()) << "no module is blamed for a kill: " << crash.dump();
    EXPECT_NE(second->err().find("died of SIGABRT from pid " + std::to_string(getpid())), std::string::npos)
        << second->err();
}

// systemd's watchdog sends SIGABRT from pid 1 (asPid1SendingSigabrt plays it).
TEST(CrashRecord, SigabrtFromPid1IsTheWatchdog) {
    if (!canBePid1()) GTEST_SKIP() << "needs root and unshare --pid";
    CrashCell cell("");
    const fs::path go = cell.dir.path / "go";
    auto first = cell.start(asPid1SendingSigabrt(go));
    std::ofstream(go) << "now\n";  // irpd runs (start() waited for it)
    first->wait(std::chrono::seconds(30));
    EXPECT_NE(cell.record().find("\nsender_pid=1\n"), std::string::npos) << cell.record() << first->err();
    auto second = cell.start();
    json crash = cell.ask({{"cmd", "status"}})["result"]["last_crash"];
    EXPECT_EQ(crash["cause"], "watchdog") << crash.dump();
    EXPECT_NE(second->err().find("died of SIGABRT from systemd's watchdog (pid 1)"), std::string::npos)
        << second->err();
}

// A thread module stuck in run() for good stops the pings; systemd's watchdog kills irpd.  The
// record names the module the stalled dispatcher is stuck in, and the restart leaves it out (its
// <on_crash> default) instead of hanging on it again and again.  The test plays systemd: the
// notify socket, then SIGABRT from pid 1 of a PID namespace once the pings stopped.
TEST(CrashRecord, TheWatchdogsKillNamesTheModuleAStalledDispatcherIsStuckIn) {
    if (!canBePid1()) GTEST_SKIP() << "needs root and unshare --pid";
    TempDir dir;
    FakeSystemd systemd{dir.path / "notify"};
    ASSERT_TRUE(systemd.bound());
    const std::string instance = uniqueInstance(), socket = (dir.path / "irpd.sock").string();
    const fs::path state = dir.path / "state", go = dir.path / "go";
    writeStallSet(dir.path);
    const std::vector<std::string> irpd = {kIrpd,
                                           "--config",
                                           (dir.path / "module.xml").string(),
                                           "--control-socket",
                                           socket,
                                           "--instance",
                                           instance,
                                           "--state-dir",
                                           state.string(),
                                           "--module-cache",
                                           (dir.path / "cache").string()};
    std::vector<std::string> wrapped = asPid1SendingSigabrt(go);
    wrapped.insert(wrapped.end(), irpd.begin(), irpd.end());
    const std::string notify = (dir.path / "notify").string();
    auto first = std::make_unique<Process>(wrapped, dir.path, [=] {
        setenv("NOTIFY_SOCKET", notify.c_str(), 1);
        setenv("WATCHDOG_USEC", "300000", 1);
        unsetenv("WATCHDOG_PID");  // irpd's pid in its namespace is not known here
        rlimit none{0, 0};
        setrlimit(RLIMIT_CORE, &none);
    });
    ASSERT_TRUE(systemd.waitFor("WATCHDOG=1", 3, std::chrono::seconds(30))) << first->err() << systemd.all();
    std::ofstream(dir.path / "stall") << "now\n";
    // The pings stopped for a second, and a second has passed since the trigger: the stall module
    // (every 2 ms on an RT thread) is inside its run() by then.  A loaded machine can delay a ping
    // by a second before the stall begins; the kill must not come then (no module to name).
    const auto stalled = Clock::now(), end = stalled + std::chrono::seconds(20);
    while ((Clock::now() - systemd.with("WATCHDOG=1").back().at < std::chrono::seconds(1) ||
            Clock::now() - stalled < std::chrono::seconds(1)) &&
           Clock::now() < end)
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::ofstream(go) << "now\n";  // systemd's watchdog fires
    first->wait(std::chrono::seconds(30));
    const std::string record = testing_support::readFile(state / (instance + ".crash"));
    EXPECT_NE(record.find("\nmodule=stall\n"), std::string::npos) << record;
    EXPECT_NE(record.find("\nexecutor=side\n"), std::string::npos) << record;
    EXPECT_NE(record.find("\nstuck=1\n"), std::string::npos) << record;

    // The restart (the trigger still there): the rest of the set runs, the stuck module is out.
    const fs::path out = dir.path / "second";
    fs::create_directory(out);
    Process second(irpd, out);
    ASSERT_TRUE(second.waitForErr("irpd: running")) << second.err();
    EXPECT_NE(second.err().find("died of SIGABRT from systemd's watchdog (pid 1) in module 'stall' on executor "
                                "'side', stuck there"),
              std::string::npos)
        << second.err();
    Client client(socket, 60);
    ASSERT_FALSE(client.readLine().empty());
    json status = client.request({{"cmd", "status"}})["result"];
    EXPECT_EQ(status["last_crash"]["cause"], "watchdog") << status.dump();
    EXPECT_EQ(status["last_crash"]["stuck"], true) << status.dump();
    ASSERT_EQ(status["left_out_after_crash"].size(), 1u) << status.dump();
    EXPECT_EQ(status["left_out_after_crash"][0]["module"], "stall") << status.dump();
    const uint64_t cycles = status["cycles"].get<uint64_t>();
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    EXPECT_GT(client.request({{"cmd", "status"}})["result"]["cycles"].get<uint64_t>(), cycles) << "the set runs";
    kill(second.pid(), SIGTERM);
    EXPECT_EQ(second.wait(std::chrono::seconds(20)), 0) << second.err();
    removeShm(instance);
}

TEST(CrashRecord, ByDefaultTheRestartLeavesTheCrashedModuleOutUntilItIsEnabled) {
    CrashCell cell("");
    cell.crashOnce();
    auto second = cell.start();  // the trigger is still there: crashy would crash again if it ran
    json status = cell.ask({{"cmd", "status"}})["result"];
    EXPECT_EQ(status["last_crash"]["module"], "crashy") << status.dump();
    EXPECT_EQ(status["last_crash"]["signal"], "SIGSEGV") << status.dump();
    EXPECT_EQ(status["left_out_after_crash"].size(), 1u) << status.dump();
    EXPECT_EQ(status["left_out_after_crash"][0]["module"], "crashy") << status.dump();
    EXPECT_TRUE(cell.hasEvent("crash", "crashy"));
    EXPECT_EQ(cell.moduleNamed("crashy")["enabled"], false);
    EXPECT_EQ(cell.moduleNamed("crashy")["state"], "disabled");
    const uint64_t healthy = cell.moduleNamed("healthy")["runs"].get<uint64_t>();
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    EXPECT_GT(cell.moduleNamed("healthy")["runs"].get<uint64_t>(), healthy) << "the rest of the set runs";
    EXPECT_EQ(cell.moduleNamed("crashy")["runs"], 0u);
    EXPECT_FALSE(fs::exists(cell.state / (cell.instance + ".crash"))) << "taken in";

    // A third start still leaves it out (the agent restoring its last set must not bring it back).
    kill(second->pid(), SIGTERM);
    ASSERT_EQ(second->wait(std::chrono::seconds(20)), 0) << second->err();
    auto third = cell.start();
    EXPECT_EQ(cell.moduleNamed("crashy")["enabled"], false);
    EXPECT_FALSE(cell.hasEvent("crash", "crashy")) << "no new crash";

    // Fixed and enabled by hand: it runs again and is no longer left out.
    cell.pull(false);
    json enabled = cell.ask({{"cmd", "enable"}, {"module", "crashy"}});
    ASSERT_TRUE(enabled.value("ok", false)) << enabled.dump();
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    EXPECT_GT(cell.moduleNamed("crashy")["runs"].get<uint64_t>(), 0u);
    EXPECT_TRUE(cell.ask({{"cmd", "status"}})["result"]["left_out_after_crash"].empty());
    EXPECT_TRUE(cell.hasEvent("crash_cleared", "crashy"));
    kill(third->pid(), SIGTERM);
    EXPECT_EQ(third->wait(std::chrono::seconds(20)), 0) << third->err();
}

TEST(CrashRecord, WithOnCrashRestartTheWholeSetRunsAgain) {
    CrashCell cell("<on_crash>restart</on_crash>");
    cell.crashOnce();
    cell.pull(false);
    auto second = cell.start();
    json status = cell.ask({{"cmd", "status"}})["result"];
    EXPECT_EQ(status["last_crash"]["module"], "crashy") << status.dump();
    EXPECT_TRUE(status["left_out_after_crash"].empty()) << status.dump();
    EXPECT_TRUE(cell.hasEvent("crash", "crashy"));
    EXPECT_EQ(cell.moduleNamed("crashy")["enabled"], true);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    EXPECT_GT(cell.moduleNamed("crashy")["runs"].get<uint64_t>(), 0u);
    kill(second->pid(), SIGTERM);
    EXPECT_EQ(second->wait(std::chrono::seconds(20)), 0) << second->err();
}

TEST(CrashRecord, ClearCrashForgetsTheRecordAndTheLeftOutModules) {
    CrashCell cell("");
    cell.crashOnce();
    auto second = cell.start();
    json cleared = cell.ask({{"cmd", "clear_crash"}});
    ASSERT_TRUE(cleared.value("ok", false)) << cleared.dump();
    EXPECT_EQ(cleared["result"]["crash"]["module"], "crashy");
    EXPECT_EQ(cleared["result"]["excluded"][0]["module"], "crashy");
    json status = cell.ask({{"cmd", "status"}})["result"];
    EXPECT_TRUE(status["last_crash"].is_null()) << status.dump();
    EXPECT_TRUE(status["left_out_after_crash"].empty()) << status.dump();
    kill(second->pid(), SIGTERM);
    ASSERT_EQ(second->wait(std::chrono::seconds(20)), 0) << second->err();
    cell.pull(false);
    auto third = cell.start();
    EXPECT_EQ(cell.moduleNamed("crashy")["enabled"], true) << "the next start runs it";
    kill(third->pid(), SIGTERM);
    EXPECT_EQ(third->wait(std::chrono::seconds(20)), 0) << third->err();
}
