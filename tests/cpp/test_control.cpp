// test_control.cpp -- irpd's control socket from a client's side: the hello, the commands, bad
// requests answered and survived, a hostile client that cannot stall irpd, the socket's life.
#include "support/control_client.hpp"
#include "support/irpd.hpp"
#include "support/subprocess.hpp"

#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <fstream>

using nlohmann::json;
using testing_support::Client;
using testing_support::kFig1;
using testing_support::kIrpd;
using testing_support::Process;
using testing_support::TempDir;
using testing_support::uniqueInstance;

namespace {

struct Running {
    TempDir dir;
    std::string socket = (dir.path / "irpd.sock").string();
    std::unique_ptr<Process> irpd;
    explicit Running(const std::string &config = kFig1) {
        irpd = std::make_unique<Process>(std::vector<std::string>{kIrpd, "--config", config, "--control-socket", socket,
                                                                  "--instance", uniqueInstance()},
                                         dir.path);
        EXPECT_TRUE(irpd->waitForErr("irpd: running")) << irpd->err();
    }
    ~Running() {
        kill(irpd->pid(), SIGTERM);
        irpd->wait(std::chrono::seconds(10));
    }
};

}  // namespace

TEST(ControlSocket, HelloThenStatusScheduleModulesStats) {
    Running r;
    Client c(r.socket);
    ASSERT_TRUE(c.connected());
    EXPECT_EQ(json::parse(c.readLine()), json::parse(R"({"protocol":"indurop-control","version":2,"irpd":"0.1.0"})"));

    json status = c.request({{"id", 1}, {"cmd", "status"}});
    EXPECT_EQ(status["id"], 1);
    ASSERT_EQ(status["ok"], true) << status;
    EXPECT_EQ(status["result"]["basic_period_ns"], 100000);
    EXPECT_EQ(status["result"]["macro_period_ns"], 500000);
    EXPECT_EQ(status["result"]["running"], true);
    EXPECT_EQ(status["result"]["modules"], 7);
    EXPECT_EQ(status["result"]["pid"], r.irpd->pid());

    json schedule = c.request({{"id", "s"}, {"cmd", "schedule"}});
    EXPECT_EQ(schedule["id"], "s");
    EXPECT_EQ(schedule["result"]["slots"][0]["modules"], json::parse(R"(["cntr3","cntr2","cntr1","cntr4"])"));

    json modules = c.request({{"cmd", "modules"}});
    ASSERT_EQ(modules["result"].size(), 7u);
    EXPECT_EQ(modules["result"][0]["name"], "cntr1");
    EXPECT_EQ(modules["result"][3]["moduletype"], "process");
    EXPECT_EQ(modules["result"][4]["operationtype"], "sporadic");

    const uint64_t before = c.request({{"cmd", "stats"}})["result"]["cycles"];
    usleep(100'000);
    const uint64_t after = c.request({{"cmd", "stats"}})["result"]["cycles"];
    EXPECT_GT(after, before);  // live figures
}

TEST(ControlSocket, BadRequestsGetAnErrorAndTheConnectionGoesOn) {
    Running r;
    Client c(r.socket);
    c.readLine();
    struct Case {
        std::string line, code, message;
    };
    for (const Case &k : {Case{"{not json", "bad_request", "not valid JSON"},
                          Case{"[1,2]", "bad_request", "a request is a JSON object with a string \"cmd\""},
                          Case{R"({"id":7})", "bad_request", "with a string \"cmd\""},
                          Case{R"({"id":8,"cmd":"reboot"})", "refused", "unknown command 'reboot'"},
                          Case{R"({"id":9,"cmd":"load"})", "refused", "'config' is required"},
                          // Above 2^63 - 1: not read as a negative period.
                          Case{R"({"cmd":"set_period","module":"cntr1","period_ns":18446744073709551615})", "refused",
                               "'period_ns' is out of range"},
                          Case{R"({"cmd":"set_priority","module":"cntr1","priority":18446744073709551615})", "refused",
                               "'priority' is out of range"}}) {
        c.sendRaw(k.line + "\n");
        json answer = json::parse(c.readLine());
        EXPECT_EQ(answer["ok"], false) << k.line;
        EXPECT_EQ(answer["error"]["code"], k.code) << k.line;
        EXPECT_NE(answer["error"]["message"].get<std::string>().find(k.message), std::string::npos) << answer;
    }
    EXPECT_EQ(c.request({{"cmd", "status"}})["ok"], true);  // still served
}

// tests/fuzz/fuzz_control: the id is echoed, and nlohmann::json copies and prints a value by
// recursion, so a 64 KiB line nested ~32000 deep could overflow the control thread's stack.
// (Seed: tests/fuzz/corpus/fuzz_control/nested-32000-deep.)
TEST(ControlSocket, ARequestNestedThousandsDeepIsRefusedNotACrash) {
    Running r;
    Client c(r.socket);
    c.readLine();
    const std::string deep = R"({"cmd":"status","id":)" + std::string(32000, '[') + std::string(32000, ']') + "}\n";
    ASSERT_LT(deep.size(), 64u * 1024);
    c.sendRaw(deep);
    json answer = json::parse(c.readLine());
    EXPECT_EQ(answer["ok"], false);
    EXPECT_EQ(answer["error"]["code"], "bad_request");
    EXPECT_NE(answer["error"]["message"].get<std::string>().find("deeper than 64 levels"), std::string::npos) << answer;
    // 64 levels, counting the request object, are still a request.
    c.sendRaw(R"({"cmd":"status","id":)" + std::string(63, '[') + std::string(63, ']') + "}\n");
    EXPECT_EQ(json::parse(c.readLine())["ok"], true);
    c.sendRaw(R"({"cmd":"status","id":"[[[[ in a string is no nesting"})"
              "\n");
    EXPECT_EQ(json::parse(c.readLine())["ok"], true);
}

TEST(ControlSocket, AnOversizedRequestClosesOnlyThatClient) {
    Running r;
    Client big(r.socket), other(r.socket);
    big.readLine();
    other.readLine();
    big.sendRaw(std::string(70 * 1024, 'x'));
    json answer = json::parse(big.readLine());
    EXPECT_EQ(answer["error"]["code"], "too_large");
    EXPECT_EQ(big.readLine(), "");  // closed
    EXPECT_EQ(other.request({{"cmd", "status"}})["ok"], true);
}

TEST(ControlSocket, AClientThatNeverReadsCannotStallIrpd) {
    Running r;
    Client hog(r.socket);
    // Thousands of requests whose answers it never reads.
    std::string many;
    for (int i = 0; i < 3000; ++i)
        many += R"({"cmd":"modules"})"
                "\n";
    hog.sendRaw(many);
    Client c(r.socket);
    c.readLine();
    const uint64_t before = c.request({{"cmd", "status"}})["result"]["cycles"];
    usleep(200'000);
    json after = c.request({{"cmd", "status"}});
    EXPECT_GT(after["result"]["cycles"].get<uint64_t>(), before + 1000);  // the grid went on
}

TEST(ControlSocket, TheSocketIsMode0660AndGoesWithIrpd) {
    std::string path;
    {
        Running r;
        path = r.socket;
        struct stat st {};
        ASSERT_EQ(stat(path.c_str(), &st), 0);
        EXPECT_TRUE(S_ISSOCK(st.st_mode));
        EXPECT_EQ(st.st_mode & 0777, 0660u);
        // A second irpd on the same socket is refused, and starts nothing.
        TempDir other;
        Process second({kIrpd, "--config", kFig1, "--control-socket", path, "--instance", uniqueInstance()},
                       other.path);
        EXPECT_EQ(second.wait(std::chrono::seconds(10)), 1);
        EXPECT_NE(second.err().find("control socket " + path + " is in use by another irpd"), std::string::npos)
            << second.err();
        EXPECT_EQ(Client(path).connected(), true);  // the first one still serves
    }
    EXPECT_NE(access(path.c_str(), F_OK), 0);  // removed at exit
}

TEST(ControlSocket, AStaleSocketIsReplacedAndAFileIsNot) {
    TempDir dir;
    const std::string path = (dir.path / "stale.sock").string();
    {  // a socket file nobody listens on, as a crashed irpd leaves it
        int fd = socket(AF_UNIX, SOCK_STREAM, 0);
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
        ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr *>(&addr), sizeof addr), 0);
        close(fd);
    }
    Process p({kIrpd, "--config", kFig1, "--control-socket", path, "--duration", "0.3", "--instance", uniqueInstance()},
              dir.path);
    EXPECT_EQ(p.wait(), 0) << p.err();

    const std::string file = (dir.path / "a-file").string();
    std::ofstream(file) << "precious";
    Process q({kIrpd, "--config", kFig1, "--control-socket", file, "--duration", "0.3", "--instance", uniqueInstance()},
              dir.path);
    EXPECT_EQ(q.wait(), 1);
    EXPECT_NE(q.err().find("exists and is not a socket"), std::string::npos) << q.err();
    EXPECT_EQ(testing_support::readFile(file), "precious");
}
