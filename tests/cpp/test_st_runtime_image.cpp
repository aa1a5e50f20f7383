// test_st_runtime_image.cpp -- the process image of the ST runtime (image.hpp, docs/st-runtime.md)
// on a real segment laid out by glbc (tests/cpp/st/st_image.glb): copyIn() takes one consistent
// read into a local and a snapshot; writeBack() writes only what the program changed, under the
// variable's lock, so that what another writer changed meanwhile survives -- also while a thread
// keeps writing the same struct.
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
