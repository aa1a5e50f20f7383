// test_shared_functions.cpp -- shared functions called from process modules (paper §3).
//   CallServer.*   irpd's serving side on a real control segment, with requests written by the
//                  test as a process would: the per-period bound, the owner check, disabled owners,
//                  irpd's own checks, withdrawn requests;
//   ProcessCalls.* libindurop's calling side in this process (INDUROP_CTL pointing at the test's
//                  segment) against a thread that serves as an executor would: answers, timeouts,
//                  a timeout while irpd is inside the function, irpd stopping;
//   IrpdCalls.*    end to end: irpd runs a set whose process modules (processes/fn_caller.cpp) call
//                  the functions of thread modules (modules/served.cpp); the owners print the
//                  cycle they served each call in, which must be one of their own slots.
#include "dispatch/function_calls.hpp"
#include "hosts/control_segment.hpp"
#include "sdk/runtime.hpp"
#include "support/subprocess.hpp"

#include <indurop/indurop.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using namespace irp;
using testing_support::Process;
using testing_support::TempDir;

namespace {

constexpr int64_t kMs = 1'000'000;

int64_t nowNs() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1'000'000'000LL + ts.tv_nsec;
}

// ---- the functions of the in-process "modules" ----------------------------------------------------

std::atomic<int> g_add_calls{0};
int32_t add(int32_t a, int32_t b) {
    ++g_add_calls;
    return a + b;
}
int32_t slowIdentity(int32_t v) {  // keeps the server inside the function for 150 ms
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    return v;
}
int32_t otherGet() { return 42; }
int32_t sporadicGet() { return 1; }

config::ModuleSpec thread(const std::string &name, int index, config::OperationType operation) {
    config::ModuleSpec m;
    m.name = name;
    m.type = config::ModuleType::Thread;
    m.operation = operation;
    m.period_ns = operation == config::OperationType::Periodic ? 1'000'000 : 0;
    m.index = index;
    return m;
}

// One control segment for the whole test program (libindurop maps INDUROP_CTL once per process):
// 12 slots, slot 0 is this process's own (its calls), the others are written by hand.
struct Harness {
    static constexpr uint32_t kSlots = 12;
    static constexpr int kUnit = 0, kOther = 1, kSporadic = 2;
    config::SetSpec set;
    std::optional<hosts::ControlSegment> control;
    std::unique_ptr<dispatch::CallServer> server;

    static Harness &get() {
        static Harness h;
        return h;
    }

    Harness() {
        set.modules = {thread("unit", kUnit, config::OperationType::Periodic),
                       thread("other", kOther, config::OperationType::Periodic),
                       thread("unit_sporadic", kSporadic, config::OperationType::Sporadic)};
        runtime::setCurrentModule("unit");
        exportFunction("unit.add", &add);
        exportFunction("unit.slow", &slowIdentity);
        runtime::setCurrentModule("other");
        exportFunction("other.get", &otherGet);
        runtime::setCurrentModule("unit_sporadic");
        exportFunction("unit_sporadic.get", &sporadicGet);
        runtime::setCurrentModule("");
        const auto exports = runtime::functionExports();
        auto c = hosts::ControlSegment::create("test-fn-" + std::to_string(getpid()), kSlots,
                                               static_cast<uint32_t>(exports.size()));
        if (!c) {
            ADD_FAILURE() << c.error().message;
            return;
        }
        control = std::move(*c);
        std::vector<std::string> notes;
        server = dispatch::CallServer::publish(*control, set, exports, notes);
        EXPECT_TRUE(notes.empty());
        setenv("INDUROP_CTL", control->name().c_str(), 1);
        setenv("INDUROP_SLOT", "0", 1);
    }

    uint32_t indexOf(const std::string &name) const {
        for (uint32_t i = 0; i < control->functionCount(); ++i)
            if (name == control->function(i).name) return i;
        ADD_FAILURE() << "no entry " << name;
        return 0;
    }
    indurop_call_area &area(uint32_t slot) { return control->slot(slot).call; }
};

uint32_t load(uint32_t &word) { return std::atomic_ref<uint32_t>(word).load(std::memory_order_acquire); }

// What libindurop does for a request, by hand: fields, then PENDING with the next tag.
uint32_t post(indurop_call_area &a, uint32_t function, const char *signature, int32_t x, int32_t y) {
    const uint32_t tag = INDUROP_CALL_TAG(load(a.word)) + 1;
    a.function = function;
    a.signature_hash = runtime::signatureHash(signature);
    a.args_size = 8;
    a.result_size = 4;
    std::memcpy(a.args, &x, 4);
    std::memcpy(a.args + 4, &y, 4);
    std::atomic_ref<uint32_t>(a.word).store((tag << 2) | INDUROP_CALL_PENDING, std::memory_order_release);
    return tag;
}
int32_t resultOf(const indurop_call_area &a) {
    int32_t r;
    std::memcpy(&r, a.result, 4);
    return r;
}
void reset(indurop_call_area &a) {
    std::atomic_ref<uint32_t>(a.word).store(load(a.word) & ~3u, std::memory_order_release);  // IDLE, tag kept
}

const char *const kAddSignature = typeid(int32_t(int32_t, int32_t)).name();

// A thread that serves `module` as its executor would, every 200 us, until destroyed.
struct ServingThread {
    std::atomic<bool> stop{false};
    std::atomic<uint64_t> cycle{0};
    std::thread thread;
    explicit ServingThread(int module) {
        thread = std::thread([this, module] {
            while (!stop.load()) {
                Harness::get().server->serve(module, cycle.fetch_add(1), false);
                std::this_thread::sleep_for(std::chrono::microseconds(200));
            }
        });
    }
    ~ServingThread() {
        stop = true;
        thread.join();
    }
};

// Every in-process test works on the harness; the first one creates it (and sets INDUROP_CTL).
class CallServer : public ::testing::Test {
protected:
    void SetUp() override { ASSERT_TRUE(Harness::get().control); }
};
class ProcessCalls : public CallServer {};

}  // namespace

// ---- irpd's side ----------------------------------------------------------------------------------

TEST_F(CallServer, TheTableSaysWhatProcessesMayCall) {
    Harness &h = Harness::get();
    ASSERT_TRUE(h.control);
    EXPECT_EQ(h.control->header()->calls, uint32_t{INDUROP_CALLS_SERVING});
    const indurop_function_entry &e = h.control->function(h.indexOf("unit.add"));
    EXPECT_STREQ(e.owner, "unit");
    EXPECT_EQ(e.owner_index, 0u);
    EXPECT_EQ(e.owner_period_ns, 1'000'000);
    EXPECT_EQ(e.args_size, 8u);
    EXPECT_EQ(e.result_size, 4u);
    EXPECT_EQ(e.refusal, uint32_t{INDUROP_CALL_OK});
    EXPECT_STREQ(e.signature, kAddSignature);
    EXPECT_EQ(h.control->function(h.indexOf("unit_sporadic.get")).refusal, uint32_t{INDUROP_CALL_NOT_SERVED});
    EXPECT_TRUE(h.server->serves(Harness::kUnit));
    EXPECT_TRUE(h.server->serves(Harness::kOther));
    EXPECT_FALSE(h.server->serves(Harness::kSporadic));  // its task never serves
}

TEST_F(CallServer, AtMostTheBoundPerPeriodAndTheRestNextPeriod) {
    Harness &h = Harness::get();
    const uint32_t fn = h.indexOf("unit.add");
    for (uint32_t s = 1; s < Harness::kSlots; ++s) post(h.area(s), fn, kAddSignature, static_cast<int32_t>(s), 100);
    const int before = g_add_calls.load();
    EXPECT_EQ(h.server->serve(Harness::kUnit, 40, false), kCallsServedPerPeriod);
    EXPECT_EQ(h.server->serve(Harness::kUnit, 42, false), Harness::kSlots - 1 - kCallsServedPerPeriod);
    EXPECT_EQ(h.server->serve(Harness::kUnit, 44, false), 0u);
    EXPECT_EQ(g_add_calls.load() - before, static_cast<int>(Harness::kSlots - 1));
    int first = 0, second = 0;
    for (uint32_t s = 1; s < Harness::kSlots; ++s) {
        indurop_call_area &a = h.area(s);
        EXPECT_EQ(INDUROP_CALL_PHASE(load(a.word)), uint32_t{INDUROP_CALL_ANSWERED}) << s;
        EXPECT_EQ(a.status, INDUROP_CALL_OK);
        EXPECT_EQ(resultOf(a), static_cast<int32_t>(s) + 100);
        (a.served_cycle == 40 ? first : second) += 1;
        EXPECT_TRUE(a.served_cycle == 40 || a.served_cycle == 42) << a.served_cycle;
        reset(a);
    }
    EXPECT_EQ(first, static_cast<int>(kCallsServedPerPeriod));
    EXPECT_EQ(second, static_cast<int>(Harness::kSlots - 1 - kCallsServedPerPeriod));
}

TEST_F(CallServer, TheScanStartsAfterTheLastServedSoNoProcessStarves) {
    Harness &h = Harness::get();
    const uint32_t fn = h.indexOf("unit.add");
    // Two full rounds: whatever waited in the first is served first in the second.
    for (uint32_t s = 1; s < Harness::kSlots; ++s) post(h.area(s), fn, kAddSignature, 1, 1);
    h.server->serve(Harness::kUnit, 1, false);
    std::vector<uint32_t> waiting;
    for (uint32_t s = 1; s < Harness::kSlots; ++s)
        if (INDUROP_CALL_PHASE(load(h.area(s).word)) == INDUROP_CALL_PENDING)
            waiting.push_back(s);
        else
            reset(h.area(s)), post(h.area(s), fn, kAddSignature, 1, 1);  // asks again at once
    ASSERT_EQ(waiting.size(), Harness::kSlots - 1 - kCallsServedPerPeriod);
    h.server->serve(Harness::kUnit, 2, false);
    for (uint32_t s : waiting) EXPECT_EQ(h.area(s).served_cycle, 2u) << "slot " << s << " starved";
    while (h.server->serve(Harness::kUnit, 3, false)) {}
    for (uint32_t s = 1; s < Harness::kSlots; ++s) reset(h.area(s));
}

TEST_F(CallServer, OnlyTheOwnersTaskTakesARequest) {
    Harness &h = Harness::get();
    indurop_call_area &a = h.area(3);
    post(a, h.indexOf("other.get"), typeid(int32_t()).name(), 0, 0);
    a.args_size = 0;
    EXPECT_EQ(h.server->serve(Harness::kUnit, 5, false), 0u);
    EXPECT_EQ(INDUROP_CALL_PHASE(load(a.word)), uint32_t{INDUROP_CALL_PENDING});
    EXPECT_EQ(h.server->serve(Harness::kOther, 6, false), 1u);
    EXPECT_EQ(a.status, INDUROP_CALL_OK);
    EXPECT_EQ(resultOf(a), 42);
    EXPECT_EQ(a.served_cycle, 6u);
    reset(a);
}

TEST_F(CallServer, ADisabledOwnerAnswersAnErrorWithoutCallingTheFunction) {
    Harness &h = Harness::get();
    indurop_call_area &a = h.area(2);
    post(a, h.indexOf("unit.add"), kAddSignature, 1, 2);
    const int before = g_add_calls.load();
    EXPECT_EQ(h.server->serve(Harness::kUnit, 9, true), 1u);
    EXPECT_EQ(a.status, INDUROP_CALL_OWNER_DISABLED);
    EXPECT_EQ(g_add_calls.load(), before);
    reset(a);
}

TEST_F(CallServer, IrpdChecksTheSignatureAndTheSizesItself) {
    Harness &h = Harness::get();
    indurop_call_area &a = h.area(4);
    post(a, h.indexOf("unit.add"), typeid(int64_t(int32_t, int32_t)).name(), 1, 2);
    const int before = g_add_calls.load();
    h.server->serve(Harness::kUnit, 1, false);
    EXPECT_EQ(a.status, INDUROP_CALL_SIGNATURE_MISMATCH);
    reset(a);
    post(a, h.indexOf("unit.add"), kAddSignature, 1, 2);
    a.args_size = 12;
    h.server->serve(Harness::kUnit, 2, false);
    EXPECT_EQ(a.status, INDUROP_CALL_BAD_REQUEST);
    EXPECT_EQ(g_add_calls.load(), before);
    reset(a);
}

TEST_F(CallServer, AWithdrawnRequestIsNeverServed) {
    Harness &h = Harness::get();
    indurop_call_area &a = h.area(5);
    const uint32_t tag = post(a, h.indexOf("unit.add"), kAddSignature, 1, 2);
    uint32_t pending = (tag << 2) | INDUROP_CALL_PENDING;
    ASSERT_TRUE(std::atomic_ref<uint32_t>(a.word).compare_exchange_strong(pending, tag << 2));  // the caller's timeout
    EXPECT_EQ(h.server->serve(Harness::kUnit, 1, false), 0u);
    EXPECT_EQ(INDUROP_CALL_PHASE(load(a.word)), uint32_t{INDUROP_CALL_IDLE});
}

// ---- the calling side (libindurop), in this process ------------------------------------------------

TEST_F(ProcessCalls, AnsweredByTheOwnersServe) {
    Harness &h = Harness::get();
    ServingThread owner(Harness::kUnit);
    SharedFunction<int32_t(int32_t, int32_t)> add_fn("unit.add");
    int32_t r = 0;
    ASSERT_EQ(add_fn(&r, 2'000 * kMs, 2, 3), 0) << lastCallError();
    EXPECT_EQ(r, 5);
    EXPECT_STREQ(lastCallError(), "");
    EXPECT_EQ(lastCallStatus(), INDUROP_CALL_OK);
    ASSERT_EQ(callFunction("unit.add", &r, 2'000 * kMs, int32_t{40}, int32_t{2}), 0) << lastCallError();
    EXPECT_EQ(r, 42);
    EXPECT_EQ(INDUROP_CALL_PHASE(load(h.area(0).word)), uint32_t{INDUROP_CALL_IDLE});
}

TEST_F(ProcessCalls, ATimeoutWithdrawsTheRequest) {
    Harness &h = Harness::get();
    const int before = g_add_calls.load();
    int32_t r = 0;
    const int64_t start = nowNs();
    EXPECT_EQ(callFunction("unit.add", &r, 20 * kMs, int32_t{1}, int32_t{1}), -1);  // nobody serves
    const int64_t took = nowNs() - start;
    EXPECT_EQ(lastCallStatus(), INDUROP_CALL_TIMEOUT);
    EXPECT_NE(std::string(lastCallError())
                  .find("shared function 'unit.add': no answer within 20 ms (irpd serves it "
                        "after each run() of module 'unit', every 1 ms)"),
              std::string::npos)
        << lastCallError();
    EXPECT_GE(took, 20 * kMs);
    EXPECT_LT(took, 1'000 * kMs);
    EXPECT_EQ(INDUROP_CALL_PHASE(load(h.area(0).word)), uint32_t{INDUROP_CALL_IDLE});
    EXPECT_EQ(h.server->serve(Harness::kUnit, 1, false), 0u);
    EXPECT_EQ(g_add_calls.load(), before);
}

TEST_F(ProcessCalls, ATimeoutWhileIrpdIsInsideTheFunctionIsSettledByTheNextCall) {
    ServingThread owner(Harness::kUnit);
    int32_t r = 0;
    EXPECT_EQ(callFunction("unit.slow", &r, 20 * kMs, int32_t{7}), -1);  // served, but takes 150 ms
    EXPECT_EQ(lastCallStatus(), INDUROP_CALL_TIMEOUT) << lastCallError();
    // The next call waits for the late answer, drops it, and gets its own.
    ASSERT_EQ(callFunction("unit.add", &r, 2'000 * kMs, int32_t{20}, int32_t{3}), 0) << lastCallError();
    EXPECT_EQ(r, 23);
}

TEST_F(ProcessCalls, CallsFromSeveralThreadsTakeTurns) {
    ServingThread owner(Harness::kUnit);
    std::atomic<int> wrong{0};
    std::vector<std::thread> callers;
    for (int t = 0; t < 4; ++t)
        callers.emplace_back([&, t] {
            SharedFunction<int32_t(int32_t, int32_t)> f("unit.add");
            for (int i = 0; i < 25; ++i) {
                int32_t r = -1;
                if (f(&r, 5'000 * kMs, t, i) != 0 || r != t + i) ++wrong;
            }
        });
    for (auto &c : callers) c.join();
    EXPECT_EQ(wrong.load(), 0);
}

TEST_F(ProcessCalls, ErrorsFoundBeforeAnyRequest) {
    int32_t r = 0;
    EXPECT_EQ(callFunction("unit.nope", &r, 10 * kMs), -1);
    EXPECT_EQ(lastCallStatus(), INDUROP_CALL_UNKNOWN_FUNCTION);
    EXPECT_NE(std::string(lastCallError())
                  .find("no module exports a shared function 'unit.nope' (the set exports 4: "
                        "other.get, unit.add, unit.slow, unit_sporadic.get"),
              std::string::npos)
        << lastCallError();
    EXPECT_EQ(callFunction("unit.add", &r, 10 * kMs, 1.0, 2.0), -1);
    EXPECT_EQ(lastCallStatus(), INDUROP_CALL_SIGNATURE_MISMATCH);
    EXPECT_NE(std::string(lastCallError())
                  .find("shared function 'unit.add' of module 'unit' is int (int, int), not int "
                        "(double, double)"),
              std::string::npos)
        << lastCallError();
    const int64_t start = nowNs();
    EXPECT_EQ(callFunction("unit_sporadic.get", &r, 5'000 * kMs), -1);
    EXPECT_LT(nowNs() - start, 1'000 * kMs);  // at once, not after the timeout
    EXPECT_EQ(lastCallStatus(), INDUROP_CALL_NOT_SERVED);
    EXPECT_EQ(callFunction("unit.add", &r, 0, int32_t{1}, int32_t{2}), -1);
    EXPECT_EQ(lastCallStatus(), INDUROP_CALL_INVALID);
    EXPECT_EQ(callFunction("", &r, 10 * kMs), -1);
    EXPECT_EQ(lastCallStatus(), INDUROP_CALL_INVALID);
    struct Big {
        char b[257];
    };
    EXPECT_EQ(callFunction("unit.add", &r, 10 * kMs, Big{}), -1);
    EXPECT_EQ(lastCallStatus(), INDUROP_CALL_TOO_LARGE);
    EXPECT_NE(std::string(lastCallError()).find("its arguments are 257 bytes, more than the 256"), std::string::npos)
        << lastCallError();
}

// Last of the in-process tests: it stops the harness's server (and serves it again afterwards).
TEST_F(ProcessCalls, IrpdStoppingEndsAWaitingCallAtOnce) {
    Harness &h = Harness::get();
    std::thread stopper([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        h.server->stop();
    });
    int32_t r = 0;
    const int64_t start = nowNs();
    EXPECT_EQ(callFunction("unit.add", &r, 20'000 * kMs, int32_t{1}, int32_t{1}), -1);
    stopper.join();
    EXPECT_LT(nowNs() - start, 5'000 * kMs);
    EXPECT_EQ(lastCallStatus(), INDUROP_CALL_STOPPED);
    EXPECT_NE(std::string(lastCallError()).find("irpd is stopping"), std::string::npos) << lastCallError();
    EXPECT_EQ(INDUROP_CALL_PHASE(load(h.area(0).word)), uint32_t{INDUROP_CALL_IDLE});
    std::atomic_ref<uint32_t>(h.control->header()->calls).store(INDUROP_CALLS_SERVING);
}

// ---- end to end through irpd --------------------------------------------------------------------

namespace {

std::string fixtureModule(const std::string &file) { return std::string(FIXTURE_MODULES) + "/" + file; }
std::string fixtureProcess(const std::string &file) { return std::string(FIXTURE_PROCESSES) + "/" + file; }

std::string threadModule(const std::string &file, const std::string &timing, int priority,
                         const std::string &extra = "") {
    return "  <module><filename>" + fixtureModule(file) + "</filename><moduletype>thread</moduletype>" + timing +
           "<priority>" + std::to_string(priority) + "</priority>" + extra + "</module>\n";
}
std::string periodic(int64_t ns) {
    return "<operationtype>periodic</operationtype><period>" + std::to_string(ns) + "</period>";
}

// The "step ..." lines of fn_caller, by step name: rc, status, value, ms, error.
struct Step {
    int rc = 99, status = -1;
    long ms = -1;
    std::string value, error;
};
std::map<std::string, Step> stepsOf(const std::string &out, const std::string &module) {
    std::map<std::string, Step> steps;
    const std::regex line("\\[" + module + "\\] step (\\S+) rc=(-?\\d+) status=(\\d+) value=(.*) ms=(\\d+) error=(.*)");
    std::istringstream in(out);
    for (std::string l; std::getline(in, l);) {
        std::smatch m;
        if (std::regex_match(l, m, line))
            steps[m[1]] = Step{std::stoi(m[2]), std::stoi(m[3]), std::stol(m[5]), m[4], m[6]};
    }
    return steps;
}

// The cycles in which an owner printed "<who>: served <what> in cycle N".
std::vector<uint64_t> servedCycles(const std::string &out, const std::string &who, const std::string &what) {
    std::vector<uint64_t> cycles;
    const std::regex line(who + ": served " + what + " in cycle (\\d+)");
    std::istringstream in(out);
    for (std::string l; std::getline(in, l);) {
        std::smatch m;
        if (std::regex_search(l, m, line)) cycles.push_back(std::stoull(m[m.size() - 1]));
    }
    return cycles;
}

}  // namespace

TEST(IrpdCalls, ProcessesCallThreadModulesFunctionsServedInTheOwnersSlots) {
    TempDir dir;
    // Basic period 500 us: fn_owner (1 ms) runs in the even cycles, fn_slow (500 ms) every 1000th,
    // fn_idle (4 s) only in cycle 0 of this 2 s run.
    const std::string xml =
        "<root>\n" + threadModule("rec_a.so", periodic(500'000), 5) +
        threadModule("fn_owner.so", periodic(1'000'000), 2) + threadModule("fn_slow.so", periodic(500'000'000), 3) +
        threadModule("fn_idle.so", periodic(4'000'000'000), 4) +
        threadModule("fn_fragile.so", periodic(1'000'000), 4,
                     "<property><value name=\"throw_at\">200</value></property>") +
        threadModule("fn_sporadic.so", "<operationtype>sporadic</operationtype><deadline>1000000</deadline>", 1) +
        "  <module><name>fn_sporadic_caller</name><filename>" + fixtureProcess("fn_caller.exe") +
        "</filename><moduletype>process</moduletype><operationtype>sporadic</operationtype>"
        "<deadline>100000000</deadline><priority>2</priority>"
        "<property><value name=\"args\">--sporadic</value></property></module>\n"
        "  <module><filename>" +
        fixtureProcess("fn_caller.exe") +
        "</filename><moduletype>process</moduletype><operationtype>non-real</operationtype></module>\n"
        "</root>\n";
    std::ofstream(dir.path / "module.xml") << xml;
    Process irpd({IRPD_PATH, "--config", (dir.path / "module.xml").string(), "--instance",
                  "test-fn-irpd-" + std::to_string(getpid()), "--duration", "2"},
                 dir.path);
    const int status = irpd.wait(std::chrono::seconds(60));
    const std::string out = irpd.out(), err = irpd.err();
    ASSERT_EQ(status, 0) << err << out;
    ASSERT_NE(out.find("[fn_caller] done"), std::string::npos) << out << err;
    auto steps = stepsOf(out, "fn_caller");

    // Results, through irpd.
    EXPECT_EQ(steps["scale"].rc, 0) << steps["scale"].error;
    EXPECT_EQ(steps["scale"].value, "10.000000");
    EXPECT_EQ(steps["scale_deduced"].value, "3.750000");
    EXPECT_EQ(steps["pair"].value, "a=7,b=2.000000") << steps["pair"].error;
    EXPECT_EQ(steps["count"].value, "10") << steps["count"].error;
    // Served in the owner's slots: fn_owner's cycles are even, fn_slow's multiples of 1000.
    const auto scale_cycles = servedCycles(out, "fn_owner", "math\\.scale\\((4|1\\.5|2)\\)");
    ASSERT_EQ(scale_cycles.size(), 3u) << out;
    for (uint64_t c : scale_cycles) EXPECT_EQ(c % 2, 0u) << "served math.scale in cycle " << c;
    const auto echo_cycles = servedCycles(out, "fn_slow", "slow\\.echo\\((\\d+)\\)");
    ASSERT_EQ(echo_cycles.size(), 2u) << out;  // echo(1) and echo(3); echo(2) was withdrawn on its timeout
    for (uint64_t c : echo_cycles) EXPECT_EQ(c % 1000, 0u) << "served slow.echo in cycle " << c;
    EXPECT_EQ(servedCycles(out, "fn_slow", "slow\\.echo\\(2\\)").size(), 0u);
    EXPECT_EQ(steps["echo1"].value, "1");
    EXPECT_EQ(steps["echo3"].value, "3");
    EXPECT_EQ(steps["echo3"].rc, 0) << steps["echo3"].error;

    // A sporadic process (released, not awaited) calls too; served in fn_owner's next slot.
    auto sporadic = stepsOf(out, "fn_sporadic_caller")["sporadic"];
    EXPECT_EQ(sporadic.rc, 0) << sporadic.error << out;
    std::smatch m;
    ASSERT_TRUE(std::regex_match(sporadic.value, m, std::regex("5 released=(\\d+)"))) << sporadic.value;
    const auto two = servedCycles(out, "fn_owner", "math\\.scale\\(2\\)");
    ASSERT_EQ(two.size(), 1u);
    EXPECT_GT(two[0], std::stoull(m[1]));

    // Every failure: -1, its status, a message that says what to do; never a hang.
    auto expectError = [&](const std::string &name, int want_status, const std::string &text) {
        const Step &s = steps[name];
        EXPECT_EQ(s.rc, -1) << name;
        EXPECT_EQ(s.status, want_status) << name << ": " << s.error;
        EXPECT_NE(s.error.find(text), std::string::npos) << name << ": " << s.error;
    };
    expectError("unknown", INDUROP_CALL_UNKNOWN_FUNCTION, "no module exports a shared function 'math.nope'");
    expectError("wrong_signature", INDUROP_CALL_SIGNATURE_MISMATCH,
                "shared function 'math.scale' of module 'fn_owner' is double (double), not int (int)");
    expectError("wrong_signature_deduced", INDUROP_CALL_SIGNATURE_MISMATCH, "is double (double), not double (int)");
    expectError(
        "too_large", INDUROP_CALL_TOO_LARGE,
        "shared function 'math.big': its arguments are 300 bytes, more than the 256 a call from a process carries");
    expectError(
        "pointer", INDUROP_CALL_NOT_TRANSFERABLE,
        "shared function 'math.peek' of module 'fn_owner' cannot be called from a process: it takes or returns a "
        "pointer");
    expectError("throws", INDUROP_CALL_THREW,
                "shared function 'math.throws' of module 'fn_owner' threw: negative input -3");
    expectError("sporadic_owner", INDUROP_CALL_NOT_SERVED, "only periodic thread modules have one");
    EXPECT_LT(steps["sporadic_owner"].ms, 1000);
    expectError("bad_timeout", INDUROP_CALL_INVALID, "the timeout must be positive");
    expectError("echo2", INDUROP_CALL_TIMEOUT,
                "shared function 'slow.echo': no answer within 5 ms (irpd serves it after each run() of module "
                "'fn_slow', every 500 ms)");
    EXPECT_GE(steps["echo2"].ms, 5);
    EXPECT_LT(steps["echo2"].ms, 400);
    expectError("fragile", INDUROP_CALL_OWNER_DISABLED, "module 'fn_fragile' is disabled (it threw from run())");
    expectError("stopped", INDUROP_CALL_STOPPED, "irpd is stopping");
    EXPECT_NE(out.find("module 'fn_fragile' threw fragile gives up from run(); disabled"), std::string::npos) << out;
}

TEST(IrpdCalls, AProcessNotStartedByIrpdIsToldSo) {
    TempDir dir;
    Process caller({"env", "-u", "INDUROP_CTL", "-u", "INDUROP_SLOT", fixtureProcess("fn_caller.exe")}, dir.path);
    ASSERT_EQ(caller.wait(std::chrono::seconds(30)), 0) << caller.err();
    auto steps = stepsOf("[x] " + std::regex_replace(caller.out(), std::regex("\n(?=.)"), "\n[x] "), "x");
    ASSERT_FALSE(steps.empty()) << caller.out();
    for (const auto &[name, s] : steps) {
        EXPECT_EQ(s.rc, -1) << name;
        if (name == "too_large") continue;  // found before anything else
        EXPECT_EQ(s.status, INDUROP_CALL_NO_IRPD) << name << ": " << s.error;
        EXPECT_NE(
            s.error.find("shared functions are called through irpd: not started by irpd (INDUROP_CTL is not set)"),
            std::string::npos)
            << name << ": " << s.error;
    }
}
