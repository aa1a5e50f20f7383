// test_alarms.cpp -- libindurop's alarm calls against a real alarm segment in this process
// (<indurop/alarms.h>, docs/alarms.md): a raise and a clear are recorded once however often they
// are called, bad ids are counted and refused, undeclared ids and cut texts are flagged, a flood is
// rate-limited without blocking or touching the records already there, many writers share the
// ring while a reader sees every record intact or counts it lost, irp::alarm in a module's run()
// allocates nothing, and irp::declareAlarm's rules.  No timing is asserted.
#include "alarms/alarm_segment.hpp"
#include "hosts/thread_module.hpp"
#include "protocol/limits.hpp"
#include "sdk/runtime.hpp"
#include "support/alarm_ring.hpp"
#include "support/allocation_counter.hpp"
#include "support/irpd.hpp"

#include <indurop/indurop.h>
#include <indurop/property.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

using irp::alarms::AlarmSegment;
using irp::alarms::Bitmap;
using testing_support::AlarmRing;
using testing_support::AllocationCounter;
using testing_support::uniqueInstance;

namespace {

constexpr uint32_t kSource = 1;

Bitmap declared(std::initializer_list<uint32_t> ids) {
    Bitmap bits{};
    for (uint32_t id : ids) irp::alarms::setBit(bits, id);
    return bits;
}

// A segment of this process's own, adopted by its libindurop, source 1 given to module "m" with
// ids 1, 2, 3 declared, and this thread writing as module "m".
struct Segment {
    AlarmSegment segment;
    explicit Segment(uint64_t capacity = irp::alarms::kDefaultCapacity,
                     uint32_t rate = static_cast<uint32_t>(irp::protocol::kAlarmRateLimit), uint32_t sources = 8)
        : segment(std::move(AlarmSegment::create(uniqueInstance(), sources, capacity, rate).value())) {
        segment.adopt();
        segment.claim(kSource, "m", declared({1, 2, 3}));
        irp::runtime::setAlarmSource(kSource);
    }
    ~Segment() { irp::runtime::setAlarmSource(irp::runtime::kNoAlarmSource); }
    indurop_alarm_source &source(uint32_t i = kSource) { return segment.source(i); }
    AlarmRing ring() { return AlarmRing(segment.header()); }
};

}  // namespace

TEST(AlarmCalls, ARaiseAndAClearAreRecordedOnceHoweverOftenTheyAreCalled) {
    Segment s;
    EXPECT_TRUE(irp::raiseAlarm(2, "axis 3", 0x8130, irp::Severity::High));
    EXPECT_FALSE(irp::raiseAlarm(2, "again"));  // active already: nothing written
    EXPECT_EQ(s.segment.view(kSource).active, std::vector<uint32_t>{2});
    EXPECT_TRUE(irp::clearAlarm(2));
    EXPECT_FALSE(irp::clearAlarm(2));
    EXPECT_FALSE(irp::clearAlarm(3));  // never raised
    EXPECT_TRUE(s.segment.view(kSource).active.empty());
    EXPECT_EQ(s.source().recorded, 2u);
    EXPECT_EQ(s.segment.header()->head, 2u);

    AlarmRing ring = s.ring();
    const auto raised = ring.read(1), cleared = ring.read(2);
    ASSERT_TRUE(raised && cleared);
    EXPECT_EQ(raised->source, kSource);
    EXPECT_EQ(raised->source_generation, s.source().generation);
    EXPECT_EQ(raised->id, 2u);
    EXPECT_EQ(raised->action, INDUROP_ALARM_RAISE);
    EXPECT_EQ(raised->severity, INDUROP_ALARM_HIGH);
    EXPECT_EQ(raised->flags, 0);
    EXPECT_EQ(raised->value, 0x8130);
    EXPECT_STREQ(raised->text, "axis 3");
    EXPECT_GT(raised->time_ns, 1'600'000'000'000'000'000);  // CLOCK_REALTIME, not the monotonic clock
    EXPECT_EQ(raised->cycle, 0u);                           // outside a dispatcher's run()
    EXPECT_EQ(cleared->action, INDUROP_ALARM_CLEAR);
    EXPECT_EQ(cleared->severity, INDUROP_ALARM_DECLARED);
    EXPECT_STREQ(cleared->text, "");
    EXPECT_GE(cleared->time_ns, raised->time_ns);
}

TEST(AlarmCalls, ALevelCalledEveryPeriodRecordsOnlyItsChanges) {
    Segment s;
    for (int period = 0; period < 1000; ++period) irp::alarm(1, period >= 100 && period < 600, "level");
    EXPECT_EQ(s.source().recorded, 2u);  // raised at 100, cleared at 600
    AlarmRing ring = s.ring();
    EXPECT_EQ(ring.read(1)->action, INDUROP_ALARM_RAISE);
    EXPECT_EQ(ring.read(2)->action, INDUROP_ALARM_CLEAR);
}

TEST(AlarmCalls, IdsOfZeroAndOver1023AreCountedAndRefused) {
    Segment s;
    EXPECT_FALSE(irp::raiseAlarm(0));
    EXPECT_FALSE(irp::raiseAlarm(1024));
    EXPECT_FALSE(irp::clearAlarm(UINT32_MAX));
    EXPECT_EQ(s.source().bad_ids, 3u);
    EXPECT_EQ(s.source().recorded, 0u);
    EXPECT_EQ(s.segment.header()->head, 0u);
    EXPECT_TRUE(irp::raiseAlarm(1023));  // the last id is one
    EXPECT_EQ(s.segment.view(kSource).active, std::vector<uint32_t>{1023});
}

TEST(AlarmCalls, AnUndeclaredIdIsRecordedFlaggedAndCounted) {
    Segment s;
    EXPECT_TRUE(irp::raiseAlarm(7, "not declared"));
    EXPECT_TRUE(irp::clearAlarm(7));
    EXPECT_TRUE(irp::raiseAlarm(3, "declared"));
    EXPECT_EQ(s.source().undeclared, 2u);
    AlarmRing ring = s.ring();
    EXPECT_EQ(ring.read(1)->flags, INDUROP_ALARM_UNDECLARED);
    EXPECT_EQ(ring.read(2)->flags, INDUROP_ALARM_UNDECLARED);
    EXPECT_EQ(ring.read(3)->flags, 0);
}

TEST(AlarmCalls, ALongDetailIsCutBeforeACharacterFlaggedAndCounted) {
    Segment s;
    const std::string long_ascii(300, 'x');
    EXPECT_TRUE(irp::raiseAlarm(1, long_ascii.c_str()));
    // 134 bytes, then a two-byte character that would end past byte 135: cut before it
    const std::string utf8 = std::string(134, 'a') + "\xC3\xA9" + "tail";
    EXPECT_TRUE(irp::raiseAlarm(2, utf8.c_str()));
    const std::string fits(INDUROP_ALARM_TEXT_CHARS - 1, 'y');
    EXPECT_TRUE(irp::raiseAlarm(3, fits.c_str()));
    AlarmRing ring = s.ring();
    EXPECT_EQ(std::string(ring.read(1)->text), std::string(INDUROP_ALARM_TEXT_CHARS - 1, 'x'));
    EXPECT_EQ(ring.read(1)->flags, INDUROP_ALARM_TRUNCATED);
    EXPECT_EQ(std::string(ring.read(2)->text), std::string(134, 'a'));
    EXPECT_EQ(ring.read(2)->flags, INDUROP_ALARM_TRUNCATED);
    EXPECT_EQ(std::string(ring.read(3)->text), fits);
    EXPECT_EQ(ring.read(3)->flags, 0);
    EXPECT_EQ(s.source().truncated, 2u);
}

TEST(AlarmCalls, WithoutASourceTheCallsDoNothing) {
    Segment s;
    irp::runtime::setAlarmSource(irp::runtime::kNoAlarmSource);  // a thread of the module's own
    EXPECT_FALSE(irp::raiseAlarm(1, "lost"));
    irp::runtime::setAlarmSource(1000);  // past source_max
    EXPECT_FALSE(irp::raiseAlarm(1, "lost"));
    EXPECT_EQ(s.segment.header()->head, 0u);
}

// More than 10,000 transitions a second from one module: at most rate_limit a second recorded,
// the rest counted, the active bitmap always right, the records already there untouched.
TEST(AlarmCalls, AFloodIsRateLimitedCountedNeverBlocksAndLeavesTheRingIntact) {
    Segment s(uint64_t{1} << 16);  // room for every record the flood could make in a minute
    ASSERT_TRUE(irp::raiseAlarm(1, "before the flood", 1));
    ASSERT_TRUE(irp::raiseAlarm(2, "before the flood", 2));
    const uint64_t before = s.source().recorded;
    constexpr int kTransitions = 20'000;
    const auto began = std::chrono::steady_clock::now();
    for (int i = 0; i < kTransitions; ++i)
        if (i % 2 == 0)
            irp::raiseAlarm(3, "flood", i);
        else
            irp::clearAlarm(3);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
    const uint64_t recorded = s.source().recorded - before, dropped = s.source().rate_dropped;
    const auto limit = static_cast<double>(s.segment.rateLimit());
    EXPECT_EQ(recorded + dropped, static_cast<uint64_t>(kTransitions));
    EXPECT_LE(static_cast<double>(recorded), limit * (seconds + 1) + 2) << seconds << " s";
    EXPECT_GE(static_cast<double>(dropped), kTransitions - limit * (seconds + 1) - 2) << seconds << " s";
    EXPECT_EQ(s.segment.view(kSource).active, (std::vector<uint32_t>{1, 2}));  // 3: cleared last
    AlarmRing ring = s.ring();
    for (uint64_t seq : {1, 2}) {
        const auto r = ring.read(seq);
        ASSERT_TRUE(r) << seq;
        EXPECT_EQ(r->id, seq);
        EXPECT_EQ(r->value, static_cast<double>(seq));
        EXPECT_STREQ(r->text, "before the flood");
    }
    // The records the flood did write are whole, in sequence.
    for (uint64_t seq = 3; seq <= s.segment.header()->head; ++seq) {
        const auto r = ring.read(seq);
        ASSERT_TRUE(r) << seq;
        EXPECT_EQ(r->id, 3u);
        EXPECT_EQ(r->action, seq % 2 ? INDUROP_ALARM_RAISE : INDUROP_ALARM_CLEAR) << seq;
    }
}

// Writers on four threads (four modules) share a small ring, so that it laps many times while a
// reader follows it: every record the reader accepts is whole, and every sequence number is either
// read or counted lost.
TEST(AlarmRing, ManyWritersAndAReaderEveryRecordIntactOrCountedLost) {
    constexpr int kWriters = 4, kPerWriter = 20'000;
    constexpr uint64_t kCapacity = 64;
    Segment s(kCapacity, UINT32_MAX, 1 + kWriters);
    for (uint32_t w = 1; w <= kWriters; ++w) s.segment.claim(w, "w" + std::to_string(w), declared({w}));
    std::atomic<int> done{0};
    std::vector<std::thread> writers;
    for (uint32_t w = 1; w <= kWriters; ++w)
        writers.emplace_back([w, &done] {
            irp::runtime::setAlarmSource(w);
            char detail[64];
            for (int n = 1; n <= kPerWriter; ++n) {
                std::snprintf(detail, sizeof detail, "writer %u record %d", w, n);
                if (n % 2)
                    irp::raiseAlarm(w, detail, n);
                else
                    irp::clearAlarm(w);
                if (n % 32 == 0) std::this_thread::yield();  // the reader gets a turn now and then
            }
            done.fetch_add(1);
        });
    AlarmRing ring = s.ring();
    uint64_t next = 1, intact = 0, lost = 0, bad = 0;
    for (;;) {
        const bool finished = done.load() == kWriters;
        const uint64_t head = __atomic_load_n(&s.segment.header()->head, __ATOMIC_ACQUIRE);
        if (next > head) {
            if (finished) break;
            std::this_thread::yield();
            continue;
        }
        const AlarmRing::Outcome o = ring.take(next, finished);
        if (o.state == AlarmRing::State::NotYet) {
            std::this_thread::yield();
            continue;
        }
        ++next;
        if (o.state == AlarmRing::State::Lost) {
            ++lost;
            continue;
        }
        ++intact;
        const indurop_alarm_record &r = o.record;
        const bool raise = r.action == INDUROP_ALARM_RAISE;
        char expect[64] = "";
        if (raise) std::snprintf(expect, sizeof expect, "writer %u record %d", r.source, static_cast<int>(r.value));
        const bool whole = r.id == r.source && r.source >= 1 && r.source <= kWriters && r.flags == 0 &&
                           std::strcmp(r.text, expect) == 0 && (raise || r.value == 0) &&
                           r.source_generation == s.segment.source(r.source).generation;
        bad += !whole;
    }
    for (std::thread &t : writers) t.join();
    uint64_t recorded = 0, collided = 0;
    for (uint32_t w = 1; w <= kWriters; ++w) {
        recorded += s.segment.source(w).recorded;
        collided += s.segment.source(w).collided;
        EXPECT_EQ(s.segment.source(w).rate_dropped, 0u);
    }
    EXPECT_EQ(bad, 0u) << intact << " intact";
    EXPECT_EQ(intact + lost, s.segment.header()->head);
    EXPECT_EQ(recorded + collided, static_cast<uint64_t>(kWriters * kPerWriter));  // every transition claimed one
    EXPECT_EQ(s.segment.header()->head, static_cast<uint64_t>(kWriters * kPerWriter));
    EXPECT_GT(intact, 0u);
    std::printf("%llu records: %llu read intact, %llu lost (%llu collided)\n",
                static_cast<unsigned long long>(s.segment.header()->head), static_cast<unsigned long long>(intact),
                static_cast<unsigned long long>(lost), static_cast<unsigned long long>(collided));
}

// ---- a module's run() ---------------------------------------------------------------------------

namespace {
irp::config::ModuleSpec alarmingSpec(std::vector<std::pair<std::string, std::string>> properties) {
    irp::config::ModuleSpec m;
    m.name = "alarming";
    m.path = std::string(FIXTURE_MODULES) + "/alarming.so";
    m.properties = std::move(properties);
    return m;
}
}  // namespace

TEST(AlarmCalls, IrpAlarmInRunAllocatesNothing) {
    Segment s;
    auto module = irp::hosts::ThreadModule::load(alarmingSpec({{"ids", "1 2 3 500"}, {"toggle_every", "10"}}));
    ASSERT_TRUE(module.ok()) << module.error().message;
    (*module)->setAlarmSource(kSource);
    ASSERT_TRUE((*module)->initialize().ok());
    ASSERT_TRUE((*module)->start().ok());
    void (*run)() = (*module)->runFunction();
    irp::runtime::setAlarmSource(kSource);  // what the dispatcher does before run()
    run();                                  // the first call: whatever a first call may set up is not counted
    long allocations = 0;
    {
        AllocationCounter counter;
        for (int i = 0; i < 1000; ++i) run();  // every 10 runs four alarms change
        allocations = counter.count();
    }
    EXPECT_EQ(allocations, 0);
    EXPECT_GE(s.source().recorded, 4u * 99);
    EXPECT_GE(s.source().undeclared, 99u);  // 500 is not declared
    (void)(*module)->stop();
}

// ---- irp::declareAlarm --------------------------------------------------------------------------

TEST(DeclareAlarm, InitializeDeclaresBesideModuleXmlsAndIrpdListsBoth) {
    Segment s;
    irp::config::ModuleSpec spec =
        alarmingSpec({{"declare", "20 high Motor overheated;8 high drive communication lost"}});
    spec.alarms.push_back({8, irp::Severity::High, "drive communication lost", 3});
    auto module = irp::hosts::ThreadModule::load(spec);
    ASSERT_TRUE(module.ok()) << module.error().message;
    (*module)->setAlarmSource(kSource);
    ASSERT_TRUE((*module)->initialize().ok());  // 8 again with the same text and severity: fine
    const auto list = irp::runtime::alarmsOf((*module)->instance());
    ASSERT_EQ(list.size(), 2u);
    EXPECT_EQ(list[0].id, 8u);
    EXPECT_FALSE(list[0].from_code);
    EXPECT_EQ(list[1].id, 20u);
    EXPECT_EQ(list[1].text, "Motor overheated");
    EXPECT_EQ(list[1].severity, irp::Severity::High);
    EXPECT_TRUE(list[1].from_code);
    // Declared at once in the module's source: a raise in start() is not flagged.
    EXPECT_TRUE(s.source().declared[0] & (uint64_t{1} << 20));
    const uint64_t instance = (*module)->instance();
    module->reset();  // unloaded: its declarations go with it
    EXPECT_TRUE(irp::runtime::alarmsOf(instance).empty());
}

TEST(DeclareAlarm, AnIdOfModuleXmlWithAnotherTextRefusesTheModule) {
    Segment s;
    irp::config::ModuleSpec spec = alarmingSpec({{"declare", "8 high comm lost"}});
    spec.alarms.push_back({8, irp::Severity::High, "drive communication lost", 3});
    auto module = irp::hosts::ThreadModule::load(spec);
    ASSERT_TRUE(module.ok()) << module.error().message;
    const irp::Status st = (*module)->initialize();
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error().message.find("alarm 8 is declared already in module.xml as 'drive communication lost'"),
              std::string::npos)
        << st.error().message;
    EXPECT_EQ(st.error().place.module, "alarming");
}

TEST(DeclareAlarm, BadDeclarationsThrowSayingWhy) {
    auto refusal = [](auto declare) -> std::string {
        try {
            declare();
        } catch (const irp::PropertyError &e) {
            return e.what();
        }
        return "accepted";
    };
    // Outside a module's initialize() or start()
    EXPECT_NE(refusal([] { irp::declareAlarm(1, irp::Severity::Low, "x"); }).find("initialize() or start()"),
              std::string::npos);
    irp::runtime::setCurrentModule("m", 4242);
    EXPECT_NE(refusal([] { irp::declareAlarm(0, irp::Severity::Low, "x"); }).find("from 1 to 1023"), std::string::npos);
    EXPECT_NE(refusal([] { irp::declareAlarm(1024, irp::Severity::Low, "x"); }).find("from 1 to 1023"),
              std::string::npos);
    EXPECT_NE(refusal([] { irp::declareAlarm(1, irp::Severity::Low, ""); }).find("empty"), std::string::npos);
    EXPECT_NE(refusal([] { irp::declareAlarm(1, irp::Severity::Low, nullptr); }).find("empty"), std::string::npos);
    const std::string long_text(static_cast<std::size_t>(irp::protocol::kAlarmTextMax) + 1, 'x');
    EXPECT_NE(refusal([&] { irp::declareAlarm(1, irp::Severity::Low, long_text.c_str()); }).find("at most 200"),
              std::string::npos);
    EXPECT_NE(refusal([] { irp::declareAlarm(1, irp::Severity::Low, "two\nlines"); }).find("control character"),
              std::string::npos);
    EXPECT_EQ(refusal([] { irp::declareAlarm(1, irp::Severity::Declared, "medium by default"); }), "accepted");
    EXPECT_EQ(irp::runtime::alarmsOf(4242).at(0).severity, irp::Severity::Medium);
    EXPECT_NE(refusal([] { irp::declareAlarm(1, irp::Severity::Low, "medium by default"); }).find("(medium)"),
              std::string::npos);
    irp::runtime::dropAlarmsOf(4242);
    irp::runtime::setCurrentModule("");
}
