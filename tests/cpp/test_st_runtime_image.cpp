// test_st_runtime_image.cpp -- the process image of the ST runtime (image.hpp, docs/st-runtime.md)
// on a real segment laid out by glbc (tests/cpp/st/st_image.glb): copyIn() takes one consistent
// read into a local and a snapshot; writeBack() writes only what the program changed, under the
// variable's lock, so that what another writer changed meanwhile survives -- also while a thread
// keeps writing the same struct; a leaf the program changed is written whole; and none of it, nor
// the rest of what generated code calls every period, allocates.
#include "support/allocation_counter.hpp"
#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"

#include <indurop/generated.h>
#include <indurop/st/st.hpp>

#include <gtest/gtest.h>
#include <unistd.h>

#include <memory>
#include <string>
#include <thread>

using namespace irp;
using st_image::mixed_t;

namespace {

// The suite's segment, made this process's segment (as irpd does before it loads modules).
class Segment : public ::testing::Environment {
public:
    void SetUp() override {
        auto layout = variables::readLayout(ST_IMAGE_LAYOUT);
        ASSERT_TRUE(layout.ok()) << layout.error().message;
        auto segment = variables::VariableSegment::create("test-st-image-" + std::to_string(getpid()), *layout);
        ASSERT_TRUE(segment.ok()) << segment.error().message;
        segment_ = std::make_unique<variables::VariableSegment>(std::move(*segment));
    }
    void TearDown() override { segment_.reset(); }

private:
    std::unique_ptr<variables::VariableSegment> segment_;
};
const auto *const kEnvironment = ::testing::AddGlobalTestEnvironment(new Segment);

uint32_t sequence(const shared::RefBase &ref) {
    return std::atomic_ref<uint32_t>(indurop_shared_locks[ref.lockIndex()].seq).load();
}

}  // namespace

TEST(StImage, AScalarIsWrittenBackOnlyWhenTheProgramChangedIt) {
    st_image::counter = 7;
    int32_t local, snapshot;
    st::copyIn(st_image::counter, local, snapshot);
    EXPECT_EQ(local, 7);
    EXPECT_EQ(snapshot, 7);
    st_image::counter = 8;  // another writer during the run
    st::writeBack(st_image::counter, local, snapshot);
    EXPECT_EQ(st_image::counter, 8);  // the program did not change it: kept

    st::copyIn(st_image::counter, local, snapshot);
    local = st::ADD(local, 1);
    st::writeBack(st_image::counter, local, snapshot);
    EXPECT_EQ(st_image::counter, 9);

    double speed, speed0;
    st_image::speed = -0.0;
    st::copyIn(st_image::speed, speed, speed0);
    speed = 0.0;  // equal as a number, another value in memory: written
    st::writeBack(st_image::speed, speed, speed0);
    EXPECT_FALSE(std::signbit(st_image::speed.load()));
}

TEST(StImage, AStructKeepsTheLeavesAnotherWriterChanged) {
    st_image::mixed = mixed_t{1, 2, 3, 4, 5.0};
    mixed_t local, snapshot;
    st::copyIn(st_image::mixed, local, snapshot);
    EXPECT_EQ(local.medium, 4);
    EXPECT_EQ(local.wide, 5.0);
    // the program changes flag and medium; another writer other, small and wide meanwhile
    local.flag = 10;
    local.medium = 40;
    st_image::mixed.other = 20;
    st_image::mixed.small = 30;
    st_image::mixed.wide = 50.0;
    const uint32_t before = sequence(st_image::mixed);
    st::writeBack(st_image::mixed, local, snapshot);
    EXPECT_EQ(sequence(st_image::mixed), before + 2);  // one write under the lock
    const mixed_t now = st_image::mixed;
    EXPECT_EQ(now.flag, 10);
    EXPECT_EQ(now.other, 20);
    EXPECT_EQ(now.small, 30);
    EXPECT_EQ(now.medium, 40);
    EXPECT_EQ(now.wide, 50.0);
}

TEST(StImage, NothingChangedMeansNoWriteAndNoLock) {
    mixed_t local, snapshot;
    st::copyIn(st_image::mixed, local, snapshot);
    const uint32_t before = sequence(st_image::mixed);
    st::writeBack(st_image::mixed, local, snapshot);
    EXPECT_EQ(sequence(st_image::mixed), before);
}

TEST(StImage, AnArrayKeepsTheElementsAnotherWriterChanged) {
    st_image::table = {1, 2, 3, 4};
    std::array<int16_t, 4> local, snapshot;
    st::copyIn(st_image::table, local, snapshot);
    local[2] = -3;
    st_image::table[1] = 22;
    st::writeBack(st_image::table, local, snapshot);
    EXPECT_EQ(st_image::table.load(), (std::array<int16_t, 4>{1, 22, -3, 4}));
}

TEST(StImage, AStringIsItsCharArray) {
    st_image::text = {};
    st::String<10> local, snapshot;
    st::copyIn(st_image::text, local, snapshot);
    EXPECT_EQ(st::LEN(local), 0);
    local = st::CONCAT(st::String("hello "), st::String("world!"));  // cut at 10
    st::writeBack(st_image::text, local, snapshot);
    const auto bytes = st_image::text.load();
    EXPECT_EQ(std::string(bytes.data()), "hello worl");
    st::copyIn(st_image::text, local, snapshot);
    EXPECT_EQ(local, st::String("hello worl"));
}

// A thread increments mixed.small under the lock, 20000 times, while the "program" runs 20000
// periods of copy-in, flag + 1, write-back: no increment is lost to a write-back, no period's flag.
TEST(StImage, WriteBackNeverLosesAConcurrentWritersUpdates) {
    st_image::mixed = mixed_t{};
    constexpr int kRounds = 20000;
    std::thread writer([] {
        for (int i = 0; i < kRounds; ++i) st_image::mixed.small += 1;
    });
    for (int i = 0; i < kRounds; ++i) {
        mixed_t local, snapshot;
        st::copyIn(st_image::mixed, local, snapshot);
        local.medium = st::ADD(local.medium, 1);
        st::writeBack(st_image::mixed, local, snapshot);
    }
    writer.join();
    const mixed_t now = st_image::mixed;
    EXPECT_EQ(now.small, kRounds);
    EXPECT_EQ(now.medium, kRounds);
}

// A leaf both the program and another writer changed in one run: with the struct's leaves, the
// program's value is written whole; without them its changed bytes are merged (documented).
TEST(StImage, WithItsLeavesAStructsChangedLeafIsWrittenWhole) {
    static constexpr st::Leaf kLeaves[] = {{0, 1}, {1, 1}, {2, 2}, {4, 4}, {8, 8}};
    st_image::mixed = mixed_t{};
    mixed_t local, snapshot;
    st::copyIn(st_image::mixed, local, snapshot);
    local.medium = 0x0001;
    local.small = 5;
    st_image::mixed.medium = 0x0100;  // the other writer, on the same leaf
    st_image::mixed.flag = 9;         // and on one the program left alone
    st::writeBack(st_image::mixed, local, snapshot, kLeaves);
    mixed_t now = st_image::mixed;
    EXPECT_EQ(now.medium, 0x0001);
    EXPECT_EQ(now.small, 5);
    EXPECT_EQ(now.flag, 9);

    st_image::mixed = mixed_t{};
    st::copyIn(st_image::mixed, local, snapshot);
    local.medium = 0x0001;
    st_image::mixed.medium = 0x0100;
    st::writeBack(st_image::mixed, local, snapshot);  // byte merge: the program's changed byte only
    now = st_image::mixed;
    EXPECT_EQ(now.medium, 0x0101);
}

TEST(StImage, AnArrayOfScalarsWritesEachChangedElementWhole) {
    st_image::table = {0, 0, 0, 0};
    std::array<int16_t, 4> local, snapshot;
    st::copyIn(st_image::table, local, snapshot);
    local[1] = 0x0001;
    st_image::table[1] = 0x0100;  // the other writer, on the same element
    st_image::table[3] = 7;
    st::writeBack(st_image::table, local, snapshot);
    EXPECT_EQ(st_image::table.load(), (std::array<int16_t, 4>{0, 0x0001, 0, 7}));

    st_image::grid = {};
    std::array<std::array<int16_t, 3>, 2> cells, cells0;  // ARRAY[1..2, 1..3] OF INT
    st::copyIn(st_image::grid, cells, cells0);
    cells[1][2] = 0x0001;
    st_image::grid[1][2] = 0x0100;
    st_image::grid[0][0] = 3;
    st::writeBack(st_image::grid, cells, cells0);
    EXPECT_EQ(st_image::grid[1][2], 0x0001);
    EXPECT_EQ(st_image::grid[0][0], 3);
}

TEST(StImage, AStringIsWrittenWholeAndAnArrayOfStringsTextByText) {
    st_image::text = {};
    st::String<10> local, snapshot;
    st::copyIn(st_image::text, local, snapshot);
    local = "abd";
    st::writeBack(st_image::text, local, snapshot);
    st::copyIn(st_image::text, local, snapshot);
    local = "abc";
    st_image::text[0] = 'x';  // the other writer: "xbd"
    st::writeBack(st_image::text, local, snapshot);
    EXPECT_EQ(std::string(st_image::text.load().data()), "abc");  // the program's text, not "xbc"

    st_image::names = {};
    std::array<st::String<5>, 3> names, names0;  // ARRAY[0..2] OF STRING[5]
    st::copyIn(st_image::names, names, names0);
    names[0] = "ann";
    names[2] = "cy";
    st_image::names[1][0] = 'B';  // another writer changes the second text
    st_image::names[2][1] = 'Z';  // and the third, which the program writes whole
    st::writeBack(st_image::names, names, names0);
    const auto now = st_image::names.load();
    EXPECT_EQ(std::string(now[0].data()), "ann");
    EXPECT_EQ(std::string(now[1].data()), "B");
    EXPECT_EQ(std::string(now[2].data()), "cy");
}

// What generated code calls every period allocates nothing: the process image, the arithmetic, the
// conversions to and from STRING, the string functions, the checks, the loop guard, the cycle time.
TEST(StImage, APeriodsWorkAllocatesNothing) {
    static constexpr st::Place kAt{"main.st", 1, 1, "PROGRAM Main"};
    mixed_t m, m0;
    std::array<int16_t, 4> t, t0;
    st::String<10> s, s0;
    int32_t c, c0;
    long allocations;
    {
        testing_support::AllocationCounter counter;
        for (int period = 0; period < 100; ++period) {
            st::copyIn(st_image::mixed, m, m0);
            st::copyIn(st_image::table, t, t0);
            st::copyIn(st_image::text, s, s0);
            st::copyIn(st_image::counter, c, c0);
            m.medium = st::ADD(m.medium, st::DIV(kAt, 10, 3));
            t[st::index(kAt, period % 4 + 1, 1, 4)] = st::MUX(kAt, period % 2, int16_t{1}, int16_t{2});
            const st::TIME elapsed = st::ADD_TIME(st::cycleTime(), st::MUL_TIME(1'000'000, 1.5));
            s = st::CONCAT(st::LEFT(st::TIME_TO_STRING(elapsed), 4), st::REAL_TO_STRING(st::LN(2.0f)));
            s = st::REPLACE(st::INSERT(s, st::String("ab"), 2), st::String("x"), 1, st::FIND(s, st::String("#")));
            c = st::ADD(c, st::STRING_TO_DINT(st::String("16#10")) + st::LREAL_TO_DINT(st::STRING_TO_LREAL(s0)));
            c = st::ADD(c, st::TIME_TO_DINT(st::STRING_TO_TIME(st::String("T#1s"))));
            st::loopCheck(kAt);
            st::writeBack(st_image::mixed, m, m0);
            st::writeBack(st_image::table, t, t0);
            st::writeBack(st_image::text, s, s0);
            st::writeBack(st_image::counter, c, c0);
        }
        allocations = counter.count();
    }
    EXPECT_EQ(allocations, 0);
    EXPECT_GT(st_image::counter.load(), 0);
}

// ---- the kept image (kept.hpp): locals and snapshots that live from one run to the next ------------

namespace {
// One module's kept image of mixed, table and text, as generated code declares it.
mixed_t km, km0;
std::array<int16_t, 4> kt, kt0;
st::String<10> ks;
st::Kept kImage[] = {
    st::kept(st_image::mixed, km, km0), st::kept(st_image::table, kt, kt0), st::kept(st_image::text, ks),  // read only
};
}  // namespace

TEST(StKept, AVariableWrittenFromOutsideBetweenRunsIsReadAgain) {
    st_image::mixed = mixed_t{1, 2, 3, 4, 5.0};
    st::copyIn(kImage);
    km.medium = 40;  // a run
    st::writeBack(kImage);
    EXPECT_EQ(st_image::mixed.medium.load(), 40);
    st::copyIn(kImage);  // nothing else wrote: the local stays as it is
    EXPECT_EQ(km.medium, 40);
    st_image::mixed.small = 33;  // another writer between two runs
    st_image::table[3] = 7;
    st::copyIn(kImage);
    EXPECT_EQ(km.small, 33);
    EXPECT_EQ(km.medium, 40);
    EXPECT_EQ(kt[3], 7);
}

TEST(StKept, AWriteFromOutsideDuringARunSurvivesAndTheNextRunReadsIt) {
    st_image::mixed = mixed_t{1, 2, 3, 4, 5.0};
    st::copyIn(kImage);
    km.flag = 10;                // the program changes flag
    st_image::mixed.wide = 9.5;  // another writer changes wide during the run
    st::writeBack(kImage);
    const mixed_t now = st_image::mixed;
    EXPECT_EQ(now.flag, 10);
    EXPECT_EQ(now.wide, 9.5);
    st::copyIn(kImage);  // the segment mixes both writers': read whole again
    EXPECT_EQ(km.flag, 10);
    EXPECT_EQ(km.wide, 9.5);
    km.flag = 11;  // and written back from the new snapshot, the other writer's value kept
    st::writeBack(kImage);
    EXPECT_EQ(st_image::mixed.wide.load(), 9.5);
    EXPECT_EQ(st_image::mixed.flag.load(), 11);
}

TEST(StKept, AVariableTheCodeOnlyReadsIsNeverWrittenBack) {
    st_image::text = {};
    st::copyIn(kImage);
    ks = st::String("mine");  // what generated code never does to a read-only variable
    const uint32_t before = sequence(st_image::text);
    st_image::text[0] = 'x';  // another writer during the run
    st::writeBack(kImage);
    EXPECT_EQ(st_image::text[0].load(), 'x');
    EXPECT_EQ(sequence(st_image::text), before + 2);  // only the other writer's write
    st::copyIn(kImage);
    EXPECT_EQ(ks.data[0], 'x');
}

TEST(StKept, AfterAFaultTheLocalsAreReadAgain) {
    st_image::mixed = mixed_t{1, 2, 3, 4, 5.0};
    st::copyIn(kImage);
    km.medium = 99;  // a run that faults: nothing is written back
    st::forget(kImage);
    st::copyIn(kImage);
    EXPECT_EQ(km.medium, 4);
    st::writeBack(kImage);
    EXPECT_EQ(st_image::mixed.medium.load(), 4);
}

TEST(StKept, OnlyTheFlaggedVariablesAreComparedAndWrittenAndTheFlagsClear) {
    st_image::mixed = mixed_t{1, 2, 3, 4, 5.0};
    st_image::table = std::array<int16_t, 4>{1, 2, 3, 4};
    bool written[3] = {};
    st::copyIn(kImage);
    written[1] = true;  // a statement that may write table ran; none that writes mixed
    kt[0] = 50;
    km.small = 77;  // what generated code never does without the flag: shows mixed is not visited
    const uint32_t mixedBefore = sequence(st_image::mixed);
    const auto small = st_image::mixed.small.load();
    st::writeBack(kImage, written);
    EXPECT_EQ(st_image::table[0].load(), 50);
    EXPECT_EQ(st_image::mixed.small.load(), small);
    EXPECT_EQ(sequence(st_image::mixed), mixedBefore);
    EXPECT_FALSE(written[0] || written[1] || written[2]);
    written[0] = true;  // flagged: compared with its snapshot, the change written
    st::writeBack(kImage, written);
    EXPECT_EQ(st_image::mixed.small.load(), 77);
    EXPECT_EQ(st_image::mixed.medium.load(), 4);
    st::copyIn(kImage);
    km.medium = 70;  // a run that faults: nothing written, the flags cleared, read again
    written[0] = true;
    st::forget(kImage, written);
    EXPECT_FALSE(written[0]);
    st::copyIn(kImage);
    EXPECT_EQ(km.medium, 4);
}

// ---- a lock group (glbc: a PROGRAM instance's structs and arrays share one lock): one sequence check
// and one taking of the lock for the group.  Here mixed and table are made one group by giving table's
// entry mixed's lock, as glbc gives the members of a group; writers of the group write under that lock.

namespace {
mixed_t gm, gm0;
std::array<int16_t, 4> gt, gt0;
constinit auto kGroup = st::grouped([] {
    std::array table{st::kept(st_image::mixed, gm, gm0), st::kept(st_image::table, gt, gt0)};
    table[1].lock = table[0].lock;
    return table;
}());

// What another writer of the group does: table's element written under the group's lock.
void writeTableAsAGroupMember(std::size_t i, int16_t v) {
    shared::detail::writeExclusive(st_image::mixed.lockIndex(), [&] {
        std::atomic_ref<int16_t>(reinterpret_cast<int16_t *>(st_image::table.address())[i]).store(v);
    });
}
}  // namespace

TEST(StKept, ALockGroupIsReadWithOneSequenceCheckAndWrittenUnderOneTakingOfTheLock) {
    EXPECT_TRUE(kGroup[0].group == 2 && kGroup[1].group == 0);
    st_image::mixed = mixed_t{1, 2, 3, 4, 5.0};
    st_image::table = std::array<int16_t, 4>{1, 2, 3, 4};
    bool written[2] = {};
    st::copyIn(kGroup);
    EXPECT_EQ(gm.medium, 4);
    EXPECT_EQ(gt[3], 4);
    gm.medium = 40;  // a run that writes both members
    gt[0] = 10;
    written[0] = written[1] = true;
    const uint32_t before = sequence(st_image::mixed);
    st::writeBack(kGroup, written);
    EXPECT_EQ(sequence(st_image::mixed), before + 2);  // the lock taken once for both
    EXPECT_EQ(st_image::mixed.medium.load(), 40);
    EXPECT_EQ(st_image::table[0].load(), 10);
    EXPECT_FALSE(written[0] || written[1]);

    gt[1] = 77;  // what generated code never does: shows that the next copy-in reads nothing
    st::copyIn(kGroup);
    EXPECT_EQ(gt[1], 77);
    gt[1] = 2;

    writeTableAsAGroupMember(2, 33);  // another writer of the group between runs: the group is read again
    st::copyIn(kGroup);
    EXPECT_EQ(gt[2], 33);
    EXPECT_EQ(gm.medium, 40);

    gm.small = 9;  // a run writes mixed while another writer changes table: both stay
    written[0] = true;
    writeTableAsAGroupMember(3, 44);
    st::writeBack(kGroup, written);
    EXPECT_EQ(st_image::mixed.small.load(), 9);
    EXPECT_EQ(st_image::table[3].load(), 44);
    st::copyIn(kGroup);  // the segment mixes two writers': read whole again
    EXPECT_EQ(gt[3], 44);
    EXPECT_EQ(gm.small, 9);
}

// ---- the compact table generated code walks (KeptImage: 20-byte rows, the groups apart), made from
// a grouped() table: the same reads and writes as the table it is made from.

namespace {
mixed_t cm, cm0;
std::array<int16_t, 4> ct, ct0;
st::String<10> cs;
constexpr auto kCompactSpec = st::grouped([] {
    std::array table{st::kept(st_image::mixed, cm, cm0), st::kept(st_image::table, ct, ct0),
                     st::kept(st_image::text, cs)};  // read only, a group of its own
    table[1].lock = table[0].lock;
    return table;
}());
constinit st::KeptImage<kCompactSpec.size(), st::groupCount(kCompactSpec)> kCompact{kCompactSpec};
}  // namespace

TEST(StKept, TheCompactTableReadsAndWritesAsItsGroupedTable) {
    static_assert(st::groupCount(kCompactSpec) == 2 && sizeof(st::KeptRow) == 20);
    st_image::mixed = mixed_t{1, 2, 3, 4, 5.0};
    st_image::table = std::array<int16_t, 4>{1, 2, 3, 4};
    st_image::text = {};
    bool written[3] = {};
    st::copyIn(kCompact);
    EXPECT_EQ(cm.medium, 4);
    EXPECT_EQ(ct[3], 4);
    cm.medium = 40;  // a run that writes both members of the group
    ct[0] = 10;
    written[0] = written[1] = true;
    const uint32_t before = sequence(st_image::mixed);
    st::writeBack(kCompact, written);
    EXPECT_EQ(sequence(st_image::mixed), before + 2);  // the lock taken once for both
    EXPECT_EQ(st_image::mixed.medium.load(), 40);
    EXPECT_EQ(st_image::table[0].load(), 10);
    EXPECT_FALSE(written[0] || written[1]);

    ct[1] = 77;  // what generated code never does: shows that the next copy-in reads nothing
    st::copyIn(kCompact);
    EXPECT_EQ(ct[1], 77);
    ct[1] = 2;

    writeTableAsAGroupMember(2, 33);  // another writer of the group between runs: read again
    st_image::text[0] = 'x';          // and of the read-only variable
    st::copyIn(kCompact);
    EXPECT_EQ(ct[2], 33);
    EXPECT_EQ(cm.medium, 40);
    EXPECT_EQ(cs.data[0], 'x');

    cm.small = 9;  // a run writes mixed while another writer changes table: both stay
    written[0] = true;
    writeTableAsAGroupMember(3, 44);
    st::writeBack(kCompact, written);
    EXPECT_EQ(st_image::mixed.small.load(), 9);
    EXPECT_EQ(st_image::table[3].load(), 44);
    st::copyIn(kCompact);
    EXPECT_EQ(ct[3], 44);

    cm.medium = 99;  // a run that faults: nothing written, the flags cleared, everything read again
    written[0] = true;
    st::forget(kCompact, written);
    EXPECT_FALSE(written[0]);
    st::copyIn(kCompact);
    EXPECT_EQ(cm.medium, 40);
}
