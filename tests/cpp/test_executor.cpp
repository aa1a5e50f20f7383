// test_executor.cpp -- the RT loop stepped with a fake clock (order, run counts, Eq. (1), overrun
// policies, budgets, faults), then the real dispatcher with real modules on the real clock.
#include "dispatch/dispatcher.hpp"
#include "dispatch/executor.hpp"
#include "hosts/module_set.hpp"
#include "journal.hpp"

#include <indurop/indurop.h>
#include "stats/summary.hpp"

#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>

using namespace irp;
using dispatch::Executor;
using dispatch::ExecutorOptions;
using dispatch::OverrunPolicy;
using dispatch::Task;

namespace {

constexpr int64_t kBasic = 100'000;

// Time moves only when the loop sleeps or a module "works".
class FakeClock final : public osal::Clock {
public:
    int64_t t = 0;
    std::function<int64_t(int64_t due)> wake_latency = [](int64_t) { return 0; };
    int64_t now() noexcept override { return t; }
    void sleepUntil(int64_t due) noexcept override {
        if (t < due) t = due;
        t += wake_latency(due);
    }
};

FakeClock *g_clock = nullptr;
std::map<std::string, int64_t> g_work;  // ns a fake module "runs"
std::string g_throw_in;                 // module that throws on its next run
// One long run: module `who` works `ns` in cycle `cycle`, calling `during` halfway through.
struct LongRun {
    std::string who;
    uint64_t cycle = UINT64_MAX;
    int64_t ns = 0;
    std::function<void()> during;
} g_long;

// Fake modules: journal the call with the cycle and the planned time, then advance the clock.
template <int N>
void fakeModule() {
    static const std::string name = "m" + std::to_string(N);
    journal::add(name.c_str(), "run", irp::cycle().count);
    g_clock->t += g_work[name];
    if (g_long.who == name && g_long.cycle == irp::cycle().count) {
        g_clock->t += g_long.ns / 2;
        if (g_long.during) g_long.during();
        g_clock->t += g_long.ns - g_long.ns / 2;
    }
    if (g_throw_in == name) {
        g_throw_in.clear();
        throw std::runtime_error("fault injected");
    }
}

struct Records {
    std::unique_ptr<stats::TimingRecord[]> r;
    explicit Records(std::size_t n) : r(new stats::TimingRecord[n]()) {
        for (std::size_t i = 0; i < n; ++i) stats::resetFigures(r[i]);
    }
    stats::TimingRecord &operator[](std::size_t i) { return r[i]; }
};

// A Figure-1-like table: m1 (1 slot, prio 1), m2 (1 slot, prio 2), m3 (5 slots, prio 3).
struct Fig1Like : ::testing::Test {
    FakeClock clock;
    Records records{4};  // 0 = dispatcher, 1..3 = m1..m3
    Task m1, m2, m3;
    std::atomic<bool> stop{false};
    std::atomic<bool> halted{false};

    void SetUp() override {
        g_clock = &clock;
        g_work.clear();
        g_long = {};
        g_throw_in.clear();
        journal::clear();
        setTask(m1, &fakeModule<1>, 1, 1);
        setTask(m2, &fakeModule<2>, 2, 1);
        setTask(m3, &fakeModule<3>, 3, 5);
    }
    void setTask(Task &t, void (*fn)(), int record, int64_t slots) {
        t.config.run = fn;
        t.config.stats = &records[static_cast<std::size_t>(record)];
        t.config.period_slots = slots;
        t.config.period_ns = slots * kBasic;
    }
    Executor make(OverrunPolicy policy = OverrunPolicy::CatchUp, int64_t max_catchup_ns = 100'000'000,
                  std::size_t sample_capacity = ExecutorOptions{}.sample_capacity) {
        std::vector<std::vector<Task *>> slots(5, std::vector<Task *>{&m1, &m2});
        slots[0].push_back(&m3);
        ExecutorOptions o;
        o.policy = policy;
        o.max_catchup_ns = max_catchup_ns;
        o.sample_capacity = sample_capacity;
        o.halted = &halted;
        return Executor(clock, kBasic, slots, {&m1, &m2, &m3}, &records[0], o);
    }
    std::vector<std::string> runsOf(uint64_t cycle) {
        std::vector<std::string> who;
        for (const auto &e : journal::entries())
            if (e.what == "run" && e.cycle == cycle) who.push_back(e.who);
        return who;
    }
    uint64_t count(const stats::Counter &c) { return c.load(); }
};

}  // namespace

TEST_F(Fig1Like, RunsEverySlotInPriorityOrder) {
    Executor e = make();
    e.loop(1'000'000, 10, stop, nullptr);
    EXPECT_EQ(runsOf(0), (std::vector<std::string>{"m1", "m2", "m3"}));
    for (uint64_t c = 1; c < 5; ++c) EXPECT_EQ(runsOf(c), (std::vector<std::string>{"m1", "m2"})) << c;
    EXPECT_EQ(runsOf(5), (std::vector<std::string>{"m1", "m2", "m3"}));
}

TEST_F(Fig1Like, RunCountsAreCyclesOverPeriod) {
    Executor e = make();
    stats::Counter cycles{0};
    e.loop(0, 1000, stop, &cycles);
    EXPECT_EQ(count(cycles), 1000u);
    EXPECT_EQ(count(records[0].runs), 1000u);
    EXPECT_EQ(count(records[1].runs), 1000u);
    EXPECT_EQ(count(records[2].runs), 1000u);
    EXPECT_EQ(count(records[3].runs), 200u);
    EXPECT_EQ(count(records[0].missed), 0u);
    EXPECT_EQ(count(records[0].overruns), 0u);
}

TEST_F(Fig1Like, WakesOnTheAbsoluteGridWithoutDrift) {
    g_work["m1"] = 30'000;  // 30 us of work must not shift the next wake-up
    Executor e = make();
    e.loop(5'000'000, 100, stop, nullptr);
    // Last slot (99) due at t0 + 99 * basic, started there, then 30 us of m1.
    EXPECT_EQ(clock.t, 5'000'000 + 99 * kBasic + 30'000);
    EXPECT_EQ(records[0].latency.max.load(), 0u);
}

TEST_F(Fig1Like, Equation1JitterIsZeroOnAConstantLatency) {
    clock.wake_latency = [](int64_t) { return 7'000; };  // every wake 7 us late
    Executor e = make();
    e.loop(0, 500, stop, nullptr);
    stats::Summary j = stats::summarize(records[0].jitter);
    EXPECT_EQ(j.min, 0);
    EXPECT_EQ(j.max, 0);
    stats::Summary l = stats::summarize(records[0].latency);
    EXPECT_EQ(l.min, 7000);
    EXPECT_EQ(l.max, 7000);
}

TEST_F(Fig1Like, Equation1JitterSeesOneLateWake) {
    clock.wake_latency = [](int64_t due) { return due == 10 * kBasic ? 40'000 : 0; };
    Executor e = make();
    e.loop(0, 100, stop, nullptr);
    // J_n = T0 + n*period - T_n: -40 us for the late one, 0 for the others.
    stats::Summary j = stats::summarize(records[0].jitter);
    EXPECT_EQ(j.min, -40'000);
    EXPECT_EQ(j.max, 0);
    EXPECT_EQ(records[0].jitter.negative.count.load(), 1u);
    // m3 (every 5th slot) was due at slot 10 too: its own Eq. (1) sees the same 40 us.
    EXPECT_EQ(stats::summarize(records[3].jitter).min, -40'000);
    EXPECT_EQ(count(records[0].missed), 0u);  // late, but less than a whole period
}

TEST_F(Fig1Like, CatchUpRunsTheLateSlotsBackToBack) {
    // Slot 10 wakes 350 us late: slots 10..13 are all past due when the loop gets the CPU.
    clock.wake_latency = [](int64_t due) { return due == 10 * kBasic ? 350'000 : 0; };
    Executor e = make(OverrunPolicy::CatchUp);
    e.loop(0, 100, stop, nullptr);
    EXPECT_EQ(count(records[1].runs), 100u);
    EXPECT_EQ(count(records[3].runs), 20u);
    EXPECT_EQ(count(records[0].skipped), 0u);
    EXPECT_EQ(count(records[0].missed), 1u);          // one wake-up came a whole period late
    EXPECT_EQ(count(records[0].caught_up), 3u);       // slots 11, 12, 13 then ran without sleeping
    EXPECT_EQ(records[0].latency.count.load(), 97u);  // only real wake-ups are latency samples
    EXPECT_EQ(stats::summarize(records[0].latency).max, 350'000);
    EXPECT_EQ(count(records[2].missed), 3u);  // m1 started slots 10, 11, 12 a whole period late
    EXPECT_EQ(count(records[3].missed), 0u);  // m3's period is 500 us: 350 us late is not a miss
}

TEST_F(Fig1Like, SkipPolicyDropsTheLateSlots) {
    clock.wake_latency = [](int64_t due) { return due == 10 * kBasic ? 350'000 : 0; };
    Executor e = make(OverrunPolicy::Skip);
    e.loop(0, 100, stop, nullptr);
    // Woke at 1.35 ms: slots 10, 11, 12 are dropped, slot 13 runs (50 us late).
    EXPECT_EQ(count(records[0].skipped), 3u);
    EXPECT_EQ(count(records[0].runs), 97u);
    EXPECT_EQ(count(records[1].runs), 97u);
    EXPECT_EQ(count(records[1].skipped), 3u);
    EXPECT_EQ(count(records[3].runs), 19u);  // slot 10 of m3 dropped
    EXPECT_EQ(count(records[3].skipped), 1u);
    EXPECT_EQ(count(records[0].missed), 1u);                       // the one wake-up that came a whole period late
    EXPECT_EQ(count(records[1].missed), 0u);                       // what ran was less than a period late
    EXPECT_EQ(stats::summarize(records[0].latency).max, 350'000);  // measured against slot 10
    EXPECT_EQ(runsOf(13), (std::vector<std::string>{"m1", "m2"}));
    EXPECT_TRUE(runsOf(11).empty());
}

// Eq. (1) counts a task's runs by its own grid (n = (due - first_due) / period), the dropped ones
// too: after a skip of many of its periods, each run still lands on T0 + n * period.
TEST_F(Fig1Like, Equation1JitterHoldsAcrossSkippedRuns) {
    clock.wake_latency = [](int64_t due) {
        if (due == 10 * kBasic) return int64_t{2'330'000};  // slots 10..32 dropped: m3's in slots 10..30
        if (due == 40 * kBasic) return int64_t{570'000};    // slots 40..44 dropped: m3's in slot 40
        return int64_t{0};
    };
    Executor e = make(OverrunPolicy::Skip);
    e.loop(0, 100, stop, nullptr);
    EXPECT_EQ(count(records[3].skipped), 6u);
    EXPECT_EQ(count(records[3].runs), 14u);
    // every run of m3 started on its grid, or late by what its slot's wake-up was late
    const stats::Summary j = stats::summarize(records[3].jitter);
    EXPECT_EQ(j.max, 0);
    EXPECT_GE(j.min, -70'000);  // slot 45 (due 4.5 ms) started at 4.57 ms
    EXPECT_EQ(records[3].jitter.negative.count.load(), 1u);
    EXPECT_EQ(stats::summarize(records[1].jitter).max, 0);
}

TEST_F(Fig1Like, CatchUpSkipsBeyondItsLimit) {
    clock.wake_latency = [](int64_t due) { return due == 10 * kBasic ? 2'050'000 : 0; };
    Executor e = make(OverrunPolicy::CatchUp, 1'000'000);  // at most 10 slots of backlog
    e.loop(0, 100, stop, nullptr);
    EXPECT_EQ(count(records[0].skipped), 20u);
    EXPECT_EQ(count(records[1].runs) + count(records[1].skipped), 100u);
    EXPECT_EQ(count(records[3].runs) + count(records[3].skipped), 20u);
}

TEST_F(Fig1Like, SlotWorkBeyondTheBasicPeriodIsAnOverrun) {
    g_work["m3"] = 120'000;  // slot 0 (and every 5th) takes 120 us of a 100 us period
    Executor e = make();
    e.loop(0, 50, stop, nullptr);
    EXPECT_EQ(count(records[0].overruns), 10u);
    EXPECT_EQ(count(records[0].runs), 50u);
    // The slot after an overrun starts at once, 20 us late; no wake-up itself was late.
    EXPECT_EQ(count(records[0].caught_up), 10u);
    EXPECT_EQ(stats::summarize(records[0].latency).max, 0);
    EXPECT_EQ(stats::summarize(records[1].latency).max, 20'000);
    // The grid holds: slot n is still due at t0 + n*basic.
    EXPECT_EQ(clock.t, 49 * kBasic);
}

TEST_F(Fig1Like, ModuleBudgetOverrunsAreCountedPerModule) {
    m2.config.budget_ns = 20'000;
    g_work["m2"] = 30'000;
    Executor e = make();
    e.loop(0, 10, stop, nullptr);
    EXPECT_EQ(count(records[2].overruns), 10u);
    EXPECT_EQ(count(records[1].overruns), 0u);
    EXPECT_EQ(count(records[0].overruns), 0u);
    EXPECT_EQ(stats::summarize(records[2].exec).max, 30'000);
}

TEST_F(Fig1Like, AThrowingModuleIsDisabledAndTheOthersGoOn) {
    g_throw_in = "m2";
    Executor e = make();
    e.loop(0, 20, stop, nullptr);
    EXPECT_EQ(count(records[2].errors), 1u);
    EXPECT_EQ(count(records[2].runs), 1u);
    EXPECT_EQ(records[2].state.load(), static_cast<uint32_t>(stats::ModuleState::Disabled));
    EXPECT_EQ(count(records[1].runs), 20u);
    EXPECT_EQ(count(records[3].runs), 4u);
}

TEST_F(Fig1Like, StopFlagEndsTheLoop) {
    stop = true;
    Executor e = make();
    e.loop(0, 0, stop, nullptr);
    EXPECT_EQ(count(records[0].runs), 0u);
}

// ---- the module figures go through the executor's sample ring into the records ----------------

// Works 1, 2, ... 10 us in cycles 0, 1, ... 9, 10, ...: a known execution-time distribution.
void variedModule() { g_clock->t += 1000 * static_cast<int64_t>(irp::cycle().count % 10 + 1); }

TEST_F(Fig1Like, TheFoldedFiguresAreWhatTheLoopMeasured) {
    setTask(m2, &variedModule, 2, 1);
    g_work["m1"] = 3000;
    Executor e = make();
    e.loop(0, 100, stop, nullptr);
    // m2's run n works (n % 10 + 1) us and starts after m1's 3 us: the histograms the RT thread
    // used to fill itself, filled here with the same values.
    stats::Histogram exec, latency;
    stats::SignedHistogram jitter;
    exec.reset();
    latency.reset();
    jitter.reset();
    for (uint64_t n = 0; n < 100; ++n) {
        exec.record(1000 * (n % 10 + 1));
        latency.record(3000);
        jitter.record(0);  // the same start in every slot: Eq. (1) sees no jitter
    }
    const stats::TimingRecord &r = records[2];
    EXPECT_EQ(count(r.runs), 100u);
    EXPECT_EQ(count(r.stats_dropped), 0u);
    for (auto [got, want] : {std::pair{&r.exec, &exec},
                             {&r.latency, &latency},
                             {&r.jitter.positive, &jitter.positive},
                             {&r.jitter.negative, &jitter.negative}}) {
        EXPECT_EQ(count(got->count), count(want->count));
        EXPECT_EQ(count(got->sum), count(want->sum));
        EXPECT_EQ(count(got->min), count(want->min));
        EXPECT_EQ(count(got->max), count(want->max));
        for (std::size_t b = 0; b < stats::kBuckets; ++b)
            ASSERT_EQ(count(got->buckets[b]), count(want->buckets[b])) << b;
    }
    EXPECT_EQ(stats::summarize(r.exec).p50, stats::summarize(exec).p50);
    EXPECT_EQ(count(records[1].exec.count), 100u);
    EXPECT_EQ(count(records[1].exec.min), 3000u);
    EXPECT_EQ(count(records[3].runs), 20u);
}

TEST_F(Fig1Like, TheRunsReachTheRecordsWhenFoldedNotBefore) {
    Executor *executor = nullptr;
    uint64_t before = 1, folded = 0, after = 0;
    g_long = {"m2", 42, 1000, [&] {
                  before = count(records[1].runs);  // 42 runs of m1 done, none folded yet
                  folded = executor->foldStats();
                  after = count(records[1].runs);
              }};
    Executor e = make();
    executor = &e;
    e.loop(0, 100, stop, nullptr);
    EXPECT_EQ(before, 0u);
    EXPECT_EQ(folded, 43u + 42u + 9u);  // m1 in slots 0..42, m2 in 0..41, m3 in 0, 5, ..., 40
    EXPECT_EQ(after, 43u);
    EXPECT_EQ(count(records[1].runs), 100u);  // the rest folded when the loop ended
    EXPECT_EQ(count(records[2].exec.count), 100u);
}

TEST_F(Fig1Like, AFullSampleRingDropsAndCountsTheFiguresAndNeverWaits) {
    Executor e = make(OverrunPolicy::CatchUp, 100'000'000, 8);  // nothing folds until the loop ends
    e.loop(0, 100, stop, nullptr);
    // Every module ran every time (the journal); the first 8 runs' figures fit: slot 0 (m1, m2,
    // m3), 1 and 2 (m1, m2), 3 (m1); the others were dropped and counted.
    EXPECT_EQ(runsOf(99), (std::vector<std::string>{"m1", "m2"}));
    EXPECT_EQ(count(records[0].runs), 100u);
    const uint64_t calls[] = {0, 100, 100, 20}, kept[] = {0, 4, 3, 1};
    for (std::size_t i = 1; i <= 3; ++i) {
        EXPECT_EQ(count(records[i].runs), kept[i]) << i;
        EXPECT_EQ(count(records[i].exec.count), kept[i]) << i;
        EXPECT_EQ(count(records[i].runs) + count(records[i].stats_dropped), calls[i]) << i;
    }
    EXPECT_EQ(count(records[0].stats_dropped), 220u - 8u);
    // What `stats`, `status` and the UI read: every record's JSON carries its loss, and the total
    // over the executors is the dispatcher's.
    EXPECT_EQ(stats::toJson(records[1]).at("stats_dropped"), 96u);
    EXPECT_EQ(stats::histogramsJson(records[3]).at("stats_dropped"), 19u);
    EXPECT_EQ(stats::statsDropped(records.r.get(), {0}), 220u - 8u);
}

// ---- the hot-reload carry-over: a kept module's task takes its predecessor's state at the swap --

TEST(TaskState, CarryOverTakesT0OnlyWhenThePeriodIsUnchanged) {
    dispatch::TaskState before;
    before.started = true;
    before.t0 = 123;
    before.first_due = 100;
    before.disabled = true;
    before.skip_until = 500;
    before.in_flight = true;
    before.deadline_missed = true;
    before.released_seq = 7;
    before.released_at = 90;

    dispatch::TaskState same;
    same.carryOver(before, /*same_period=*/true, /*clear_fault=*/false);
    EXPECT_TRUE(same.started);
    EXPECT_EQ(same.t0, 123);
    EXPECT_EQ(same.first_due, 100);
    EXPECT_TRUE(same.disabled);
    EXPECT_EQ(same.skip_until, 500);
    EXPECT_TRUE(same.in_flight);
    EXPECT_TRUE(same.deadline_missed);
    EXPECT_EQ(same.released_seq, 7u);
    EXPECT_EQ(same.released_at, 90);

    dispatch::TaskState changed;  // another period, and enabled again
    changed.carryOver(before, /*same_period=*/false, /*clear_fault=*/true);
    EXPECT_FALSE(changed.started);
    EXPECT_EQ(changed.t0, 0);
    EXPECT_FALSE(changed.disabled);
    EXPECT_EQ(changed.skip_until, 500);  // the rest goes on as before
    EXPECT_TRUE(changed.in_flight);
    EXPECT_EQ(changed.released_seq, 7u);

    dispatch::TaskState by_request;  // disabled by the new generation itself: clear_fault does not enable it
    by_request.disabled = true;
    by_request.carryOver(before, true, true);
    EXPECT_TRUE(by_request.disabled);
}

namespace {
// The table a swap offers: k1 (2 slots), k2 and k3 taking over from m1, m2, m3; 10 slots.
struct Successors {
    Task k1, k2, k3;
    dispatch::Table table;
    Successors(const Task &m1, const Task &m2, const Task &m3) : k1(m1.config), k2(m2.config), k3(m3.config) {
        for (auto [k, m] : {std::pair{&k1, &m1}, {&k2, &m2}, {&k3, &m3}}) k->config.predecessor = m;
        k1.config.period_slots = 2;
        k1.config.period_ns = 2 * kBasic;  // a changed period: its T0 starts again
        table.basic_ns = kBasic;
        table.slots.resize(10);
        for (std::size_t i = 0; i < 10; ++i) {
            if (i % 2 == 0) table.slots[i].push_back(&k1);
            table.slots[i].push_back(&k2);
            if (i % 5 == 0) table.slots[i].push_back(&k3);
        }
        table.tasks = {&k1, &k2, &k3};
    }
};
}  // namespace

TEST_F(Fig1Like, ASwapCarriesTheKeptTasksStateOver) {
    g_throw_in = "m2";  // m2 throws in cycle 0: disabled by a fault
    Executor e = make();
    Successors next(m1, m2, m3);
    e.offer(&next.table, 10 * kBasic);
    e.loop(0, 30, stop, nullptr);
    ASSERT_TRUE(e.switched().has_value());
    EXPECT_EQ(e.switched()->cycle, 10u);
    EXPECT_TRUE(next.k2.state.disabled);  // the fault's disable goes on
    for (uint64_t c = 10; c < 30; ++c) {
        const std::vector<std::string> who = runsOf(c);
        EXPECT_EQ(std::count(who.begin(), who.end(), "m2"), 0) << c;
    }
    EXPECT_EQ(next.k3.state.t0, m3.state.t0);  // same period: Eq. (1)'s T0 goes on
    EXPECT_TRUE(next.k3.state.started);
    EXPECT_EQ(next.k1.state.t0, 10 * kBasic);  // new period: a new T0, at the swap
    EXPECT_NE(m1.state.t0, next.k1.state.t0);
    EXPECT_FALSE(m1.state.disabled);  // the predecessor itself is only read
}

TEST_F(Fig1Like, ASwapWithClearFaultRunsAFaultDisabledModuleAgain) {
    g_throw_in = "m2";
    Executor e = make();
    Successors next(m1, m2, m3);
    next.k2.config.clear_fault = true;  // enable: the new task does not inherit the disable
    e.offer(&next.table, 10 * kBasic);
    e.loop(0, 30, stop, nullptr);
    EXPECT_TRUE(m2.state.disabled);
    EXPECT_FALSE(next.k2.state.disabled);
    for (uint64_t c = 10; c < 30; ++c) {
        const std::vector<std::string> who = runsOf(c);
        EXPECT_EQ(std::count(who.begin(), who.end(), "m2"), 1) << c;
    }
}

// ---- the per-module overrun watchdog (<on_overrun>, docs/faults.md) ---------------------------

namespace {
using config::OverrunAction;
using dispatch::Fault;

std::vector<Fault> outcomes(Executor &e) {
    std::vector<Fault> all;
    Fault f;
    while (e.marker().take(f)) all.push_back(f);
    return all;
}
}  // namespace

TEST_F(Fig1Like, OverrunWarnCountsItAndChangesNothingElse) {
    m2.config.on_overrun = OverrunAction::Warn;
    m2.config.overrun_limit_ns = 100'000;
    g_long = {"m2", 10, 350'000, {}};
    Executor e = make();
    e.loop(0, 100, stop, nullptr);
    EXPECT_EQ(count(records[2].overruns), 1u);
    EXPECT_EQ(count(records[2].runs), 100u);  // caught up: every run made
    EXPECT_EQ(count(records[2].skipped), 0u);
    EXPECT_NE(records[2].state.load(), static_cast<uint32_t>(stats::ModuleState::Disabled));
    EXPECT_FALSE(halted.load());
    const auto faults = outcomes(e);
    ASSERT_EQ(faults.size(), 1u);
    EXPECT_EQ(faults[0].kind, Fault::Kind::Returned);
    EXPECT_EQ(faults[0].action, OverrunAction::Warn);
    EXPECT_EQ(faults[0].record, &records[2]);
    EXPECT_EQ(faults[0].elapsed_ns, 350'000);
    EXPECT_FALSE(faults[0].seen_running);  // no watchdog looked
}

TEST_F(Fig1Like, AShortRunIsNoOverrunWhateverTheAction) {
    m2.config.on_overrun = OverrunAction::Stop;
    m2.config.overrun_limit_ns = 100'000;
    g_work["m2"] = 60'000;
    Executor e = make();
    e.loop(0, 50, stop, nullptr);
    EXPECT_EQ(count(records[2].overruns), 0u);
    EXPECT_EQ(count(records[2].runs), 50u);
    EXPECT_FALSE(halted.load());
    EXPECT_TRUE(outcomes(e).empty());
}

TEST_F(Fig1Like, OverrunSkipDropsTheRunsItMissedAndTheOthersCatchUp) {
    m2.config.on_overrun = OverrunAction::Skip;
    m2.config.overrun_limit_ns = 100'000;
    g_long = {"m2", 10, 350'000, {}};  // slot 10's m2 ends at 1.35 ms: slots 11, 12, 13 were due
    Executor e = make();
    e.loop(0, 100, stop, nullptr);
    EXPECT_EQ(count(records[2].skipped), 3u);
    EXPECT_EQ(count(records[2].runs), 97u);
    EXPECT_EQ(count(records[2].runs) + count(records[2].skipped), 100u);
    EXPECT_EQ(count(records[1].runs), 100u);  // m1 caught up
    EXPECT_EQ(count(records[3].runs), 20u);
    EXPECT_EQ(runsOf(13), (std::vector<std::string>{"m1"}));
    EXPECT_EQ(runsOf(14), (std::vector<std::string>{"m1", "m2"}));
    EXPECT_EQ(count(records[2].overruns), 1u);
}

TEST_F(Fig1Like, OverrunDisableTakesTheModuleOutAndTheRestRunsOn) {
    m2.config.on_overrun = OverrunAction::Disable;
    m2.config.overrun_limit_ns = 100'000;
    g_long = {"m2", 10, 350'000, {}};
    Executor e = make();
    e.loop(0, 100, stop, nullptr);
    EXPECT_EQ(count(records[2].runs), 11u);  // cycles 0..10
    EXPECT_EQ(records[2].state.load(), static_cast<uint32_t>(stats::ModuleState::Disabled));
    EXPECT_EQ(count(records[1].runs), 100u);
    EXPECT_EQ(count(records[3].runs), 20u);
    EXPECT_EQ(count(records[2].errors), 0u);  // not an exception
    const auto faults = outcomes(e);
    ASSERT_EQ(faults.size(), 1u);
    EXPECT_EQ(faults[0].action, OverrunAction::Disable);
}

TEST_F(Fig1Like, OverrunStopHaltsEveryModuleButTheGridGoesOn) {
    m2.config.on_overrun = OverrunAction::Stop;
    m2.config.overrun_limit_ns = 100'000;
    g_long = {"m2", 10, 350'000, {}};
    Executor e = make();
    e.loop(0, 100, stop, nullptr);
    EXPECT_TRUE(halted.load());
    EXPECT_EQ(count(records[1].runs), 11u);  // m1 ran before m2 in slot 10, then nothing
    EXPECT_EQ(count(records[2].runs), 11u);
    EXPECT_EQ(count(records[3].runs), 2u);    // slots 0 and 5; slot 10's m3 came after m2
    EXPECT_EQ(count(records[0].runs), 100u);  // the loop still keeps its time grid
    EXPECT_EQ(clock.t, 99 * kBasic);
}

TEST_F(Fig1Like, TheWatchdogSeesARunStillGoingAndStopsTheSetBeforeItReturns) {
    m2.config.on_overrun = OverrunAction::Stop;
    m2.config.overrun_limit_ns = 100'000;
    Executor e = make();
    std::vector<Fault> reported;
    std::vector<std::string> stops;  // what the stop hook saw, in order
    dispatch::Watchdog::Hooks hooks;
    hooks.report = [&](const Fault &f) { reported.push_back(f); };
    hooks.stop = [&](const Fault &f) { stops.push_back(f.kind == Fault::Kind::Running ? "while running" : "after"); };
    dispatch::Watchdog watchdog(clock, {&e}, halted, hooks);
    int64_t next_look = 0;
    // m2 runs 10 ms in slot 10 (started at 1.0 ms); halfway, the watchdog looks at 6.0 ms: past
    // the limit (1.1 ms).  A look before the limit reports nothing and comes back at the limit.
    g_long = {"m2", 10, 10'000'000, [&] {
                  EXPECT_EQ(watchdog.check(10 * kBasic + 50'000), 10 * kBasic + 100'000 + 1);
                  EXPECT_TRUE(reported.empty());
                  next_look = watchdog.check(clock.t);
                  EXPECT_TRUE(halted.load());                             // the other executors stop at once
                  EXPECT_EQ(watchdog.check(clock.t + 1), next_look + 1);  // reported once per run
              }};
    e.loop(0, 200, stop, nullptr);
    ASSERT_EQ(stops, (std::vector<std::string>{"while running"}));
    ASSERT_EQ(reported.size(), 1u);
    EXPECT_EQ(reported[0].kind, Fault::Kind::Running);
    EXPECT_EQ(reported[0].elapsed_ns, 5'000'000);
    EXPECT_EQ(reported[0].record, &records[2]);
    EXPECT_NE(watchdog.stoppedBy().find("on_overrun=stop"), std::string::npos) << watchdog.stoppedBy();
    // After it returned: the outcome is reported as seen while running, and the stop is not repeated.
    watchdog.check(clock.t);
    ASSERT_EQ(reported.size(), 2u);
    EXPECT_EQ(reported[1].kind, Fault::Kind::Returned);
    EXPECT_TRUE(reported[1].seen_running);
    EXPECT_EQ(stops.size(), 1u);
    EXPECT_EQ(count(records[2].runs), 11u);
    EXPECT_EQ(count(records[1].runs), 11u);
}

TEST_F(Fig1Like, AnOverrunStopFoundOnlyAfterTheRunIsStillActedOnByTheWatchdog) {
    m2.config.on_overrun = OverrunAction::Stop;
    m2.config.overrun_limit_ns = 100'000;
    g_long = {"m2", 3, 500'000, {}};
    Executor e = make();
    int stops = 0;
    dispatch::Watchdog::Hooks hooks;
    hooks.stop = [&](const Fault &f) {
        ++stops;
        EXPECT_EQ(f.kind, Fault::Kind::Returned);
    };
    dispatch::Watchdog watchdog(clock, {&e}, halted, hooks);
    e.loop(0, 20, stop, nullptr);
    watchdog.check(clock.t);
    EXPECT_EQ(stops, 1);
    EXPECT_FALSE(watchdog.stoppedBy().empty());
}

// ---- the real dispatcher, real modules, real clock --------------------------------------------

namespace {

config::SetSpec recorderSet(const std::string &extra_module_xml = "") {
    std::string xml = R"(<root>
  <module><filename>rec_a.so</filename><moduletype>thread</moduletype><operationtype>periodic</operationtype>
          <period>500000</period><priority>3</priority></module>
  <module><filename>rec_b.so</filename><moduletype>thread</moduletype><operationtype>periodic</operationtype>
          <period>100000</period><priority>2</priority></module>
  <module><filename>rec_c.so</filename><moduletype>thread</moduletype><operationtype>periodic</operationtype>
          <period>100000</period><priority>1</priority></module>
  <module><filename>desc_a.so</filename><moduletype>thread</moduletype><operationtype>periodic</operationtype>
          <period>500000</period><priority>3</priority></module>
)" + extra_module_xml +
                      "</root>";
    auto set = config::parseModuleXmlText(xml, std::string(FIXTURE_MODULES) + "/module.xml");
    EXPECT_TRUE(set.ok()) << set.error().message;
    return *set;
}

struct RealRun {
    std::unique_ptr<hosts::ModuleSet> modules;
    std::unique_ptr<stats::StatsSegment> segment;
    std::unique_ptr<dispatch::Tables> tables;
    std::unique_ptr<dispatch::Dispatcher> dispatcher;
};

// during: called while the set runs (between the dispatcher's start and its join).
RealRun runFor(const config::SetSpec &set, int64_t duration_ns,
               const std::function<void(const RealRun &)> &during = {}) {
    RealRun run;
    auto schedule = schedule::build(set, {});
    EXPECT_TRUE(schedule.ok());
    auto modules = hosts::ModuleSet::load(set);
    EXPECT_TRUE(modules.ok()) << modules.error().message;
    run.modules = std::move(*modules);
    auto segment = stats::StatsSegment::create("test-executor-" + std::to_string(getpid()),
                                               dispatch::Dispatcher::executorCount(set) + set.modules.size());
    EXPECT_TRUE(segment.ok()) << segment.error().message;
    run.segment = std::make_unique<stats::StatsSegment>(std::move(*segment));
    std::vector<dispatch::ModuleBinding> bindings;
    const std::size_t first = dispatch::Dispatcher::executorCount(set);
    for (std::size_t i = 0; i < set.modules.size(); ++i) {
        const auto &m = set.modules[i];
        auto &r = run.segment->describe(first + i, stats::RecordKind::Module, m.name, m.executor, m.period_ns,
                                        m.priority, m.budget_ns);
        dispatch::ModuleBinding b;
        b.stats = &r;
        if (auto *module = run.modules->module(i)) {
            b.run = module->runFunction();
            b.condition = module->table().condition;
        }
        bindings.push_back(b);
    }
    EXPECT_TRUE(run.modules->initializeAll().ok());
    EXPECT_TRUE(run.modules->startAll().ok());
    dispatch::DispatcherOptions options;
    run.tables = dispatch::buildTables(set, *schedule, bindings);
    run.dispatcher =
        std::make_unique<dispatch::Dispatcher>(set, *run.tables, *run.segment, options, osal::monotonicClock());
    EXPECT_TRUE(run.dispatcher->start(duration_ns).ok());
    if (during) during(run);
    run.dispatcher->join();
    EXPECT_TRUE(run.modules->stopAll().empty());
    return run;
}

}  // namespace

TEST(RealDispatcher, RunsTheFigure1ShapeForOneSecondInOrder) {
    journal::clear();
    config::SetSpec set = recorderSet();
    RealRun run = runFor(set, 1'200'000'000);
    const stats::TimingRecord &dispatcher = run.segment->record(0);
    // Exactly duration / period, counting slots the overrun policy may have dropped on a stall.
    EXPECT_EQ(dispatcher.runs.load() + dispatcher.skipped.load(), 12000u);
    const uint64_t expected[] = {2400, 12000, 12000, 2400};
    for (std::size_t i = 0; i < 4; ++i) {
        const stats::TimingRecord &r = run.segment->record(1 + i);
        EXPECT_EQ(r.runs.load() + r.skipped.load(), expected[i]) << r.name;
    }

    // In every cycle: rec_c (1) > rec_b (2) > rec_a (3) > desc_a (3, later in the file), lifecycle around.
    auto entries = journal::entries();
    std::map<uint64_t, std::vector<std::string>> by_cycle;
    std::map<std::string, std::vector<std::string>> lifecycle;
    for (const auto &e : entries) {
        if (e.what == "run")
            by_cycle[e.cycle].push_back(e.who);
        else
            lifecycle[e.who].push_back(e.what);
    }
    ASSERT_GT(by_cycle.size(), 11000u);
    for (const auto &[cycle, who] : by_cycle) {
        if (cycle % 5 == 0)
            ASSERT_EQ(who, (std::vector<std::string>{"rec_c", "rec_b", "rec_a", "desc_a"})) << "cycle " << cycle;
        else
            ASSERT_EQ(who, (std::vector<std::string>{"rec_c", "rec_b"})) << "cycle " << cycle;
    }
    for (const char *m : {"rec_a", "rec_b", "rec_c", "desc_a"})
        EXPECT_EQ(lifecycle[m], (std::vector<std::string>{"initialize", "start", "stop"})) << m;
    // Lifecycle order across the set: all initialize, then all start, then the runs, then all stop.
    std::vector<std::string> phases;
    for (const auto &e : entries)
        if (phases.empty() || phases.back() != e.what) phases.push_back(e.what);
    EXPECT_EQ(phases, (std::vector<std::string>{"initialize", "start", "run", "stop"}));
}

TEST(RealDispatcher, TheStatsThreadFoldsTheRunsWhileTheSetRunsAndAllOfThemByTheEnd) {
    journal::clear();
    uint64_t seen_live = 0;
    bool running_then = false;
    RealRun run = runFor(recorderSet(), 1'000'000'000, [&](const RealRun &r) {
        const stats::TimingRecord &rec_b = r.segment->record(1 + 1);
        for (int i = 0; i < 5000 && seen_live == 0; ++i) {  // the runs appear while it runs, not at the end
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
            seen_live = rec_b.runs.load();
            running_then = !r.dispatcher->finished();
        }
    });
    EXPECT_GT(seen_live, 0u);
    EXPECT_TRUE(running_then);
    std::map<std::string, uint64_t> journaled;  // what the modules themselves did
    for (const auto &e : journal::entries())
        if (e.what == "run") ++journaled[e.who];
    for (std::size_t i = 1; i <= 4; ++i) {
        const stats::TimingRecord &r = run.segment->record(i);
        EXPECT_EQ(r.runs.load() + r.stats_dropped.load(), journaled[r.name]) << r.name;
        EXPECT_EQ(r.exec.count.load(), r.runs.load()) << r.name;
        EXPECT_EQ(r.latency.count.load(), r.runs.load()) << r.name;
        EXPECT_EQ(r.jitter.negative.count.load() + r.jitter.positive.count.load(), r.runs.load()) << r.name;
    }
}

TEST(RealDispatcher, ASlowModuleRunsOnItsOwnExecutorAndTimeGrid) {
    journal::clear();
    // rec_d spins 3 ms every 10 ms on executor "slow"; the 100 us modules stay on "main".
    config::SetSpec set = recorderSet(R"(
  <executor><name>slow</name><rtpriority>70</rtpriority></executor>
  <module><filename>rec_d.so</filename><moduletype>thread</moduletype><operationtype>periodic</operationtype>
          <period>10000000</period><priority>9</priority><executor>slow</executor>
          <property><value name="busy_ns">3000000</value></property></module>
)");
    RealRun run = runFor(set, 500'000'000);
    const stats::TimingRecord &main = run.segment->record(0);
    const stats::TimingRecord &slow = run.segment->record(1);
    EXPECT_STREQ(slow.name, "dispatcher@slow");
    EXPECT_EQ(slow.period_ns, 10'000'000);  // its own basic period: the GCD of its modules
    EXPECT_EQ(main.runs.load() + main.skipped.load(), 5000u);
    EXPECT_EQ(slow.runs.load() + slow.skipped.load(), 50u);
    const stats::TimingRecord &rec_d = run.segment->record(2 + 4);
    EXPECT_STREQ(rec_d.name, "rec_d");
    EXPECT_EQ(rec_d.runs.load() + rec_d.skipped.load(), 50u);
    // On its own executor, rec_d's cycle counts that executor's 10 ms periods.
    std::vector<uint64_t> cycles;
    for (const auto &e : journal::entries())
        if (e.who == "rec_d" && e.what == "run") cycles.push_back(e.cycle);
    ASSERT_FALSE(cycles.empty());
    EXPECT_EQ(cycles.front(), 0u);
    EXPECT_LT(cycles.back(), 50u);
}

TEST(RealDispatcher, ASporadicModuleFiresInTheBasicPeriodItsConditionTurnsTrue) {
    journal::clear();
    std::string xml = R"(<root>
  <module><filename>event_source.so</filename><moduletype>thread</moduletype><operationtype>periodic</operationtype>
          <period>100000</period><priority>1</priority>
          <property><value name="at">7 300 301 2999</value></property></module>
  <module><filename>event_handler.so</filename><moduletype>thread</moduletype><operationtype>sporadic</operationtype>
          <deadline>100000</deadline><priority>1</priority></module>
</root>)";
    auto set = config::parseModuleXmlText(xml, std::string(FIXTURE_MODULES) + "/module.xml");
    ASSERT_TRUE(set.ok()) << set.error().message;
    RealRun run = runFor(*set, 300'000'000);
    std::vector<std::pair<std::string, uint64_t>> events;
    for (const auto &e : journal::entries()) events.emplace_back(e.who + ":" + e.what, e.cycle);
    // The event handler runs after the periodic modules of the same basic period.
    using E = std::pair<std::string, uint64_t>;
    EXPECT_EQ(events, (std::vector<E>{{"source:raise", 7},
                                      {"handler:run", 7},
                                      {"source:raise", 300},
                                      {"handler:run", 300},
                                      {"source:raise", 301},
                                      {"handler:run", 301},
                                      {"source:raise", 2999},
                                      {"handler:run", 2999}}));
    const stats::TimingRecord &handler = run.segment->record(1 + 1);
    EXPECT_STREQ(handler.name, "event_handler");
    EXPECT_EQ(handler.runs.load(), 4u);
}
