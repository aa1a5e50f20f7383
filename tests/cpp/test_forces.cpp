// test_forces.cpp -- the force table on a variables segment of the test's own (docs/forcing.md): a
// forced leaf (a struct member) is written back over what a writer left, under its variable's
// sequence, and applying allocates nothing; a struct or an array as a whole cannot be forced; a
// table is freed only once every reader took a newer one.
#include "support/allocation_counter.hpp"

#include "dispatch/forces.hpp"
#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"
#include "variables/variable_write.hpp"

#include <indurop/generated.h>
#include <indurop/shared.h>

#include <gtest/gtest.h>

#include <unistd.h>

using namespace irp;

namespace {

const std::string kLayout = std::string(BUILD_ROOT) + "/sets/paper-fig1/layout.json";

struct Forces : ::testing::Test {
    void SetUp() override {
        auto read = variables::readLayout(kLayout);
        ASSERT_TRUE(read.ok()) << read.error().message;
        layout = nlohmann::json::parse(read->text);
        auto created = variables::VariableSegment::create("test-forces-" + std::to_string(getpid()), *read);
        ASSERT_TRUE(created.ok()) << created.error().message;
        segment = std::make_unique<variables::VariableSegment>(std::move(*created));
    }
    dispatch::ForcedLeaf forced(const std::string &path, const nlohmann::json &value) {
        auto leaf = variables::findLeaf(layout, path);
        EXPECT_TRUE(leaf.ok()) << leaf.error().message;
        auto bytes = variables::encodeValue(*leaf, value);
        EXPECT_TRUE(bytes.ok()) << bytes.error().message;
        dispatch::ForcedLeaf f{leaf->offset, leaf->size, leaf->lock};
        std::memcpy(f.value, bytes->data(), sizeof f.value);
        return f;
    }
    nlohmann::json layout;
    std::unique_ptr<variables::VariableSegment> segment;
};

}  // namespace

TEST_F(Forces, AForcedMemberIsWrittenBackOverAWriterUnderItsSequenceWithoutAllocating) {
    using knu::Robot::joints;
    using knu::Robot::tick;
    dispatch::ForceBoard board;
    board.publish({forced("knu.Robot.joints[1].y", 2.5), forced("knu.Robot.tick", 40)});
    const uint32_t sequence = shared::detail::sequence(1).load();
    long allocations = 0;
    {
        testing_support::AllocationCounter counter;
        for (int period = 0; period < 1000; ++period) {
            joints[1].y = period;  // a module writes it every period
            tick = tick + 1;
            dispatch::applyForces(board.current());
        }
        allocations = counter.count();
    }
    EXPECT_EQ(allocations, 0) << "applying the forces allocates nothing";
    EXPECT_EQ(static_cast<double>(joints[1].y), 2.5);
    EXPECT_EQ(static_cast<uint32_t>(tick), 40u);
    const uint32_t after = shared::detail::sequence(1).load();
    EXPECT_EQ(after % 2, 0u) << "the whole-struct readers' sequence is even again";
    EXPECT_EQ(after - sequence, 4u * 1000) << "each write and each force went through the sequence";
    dispatch::applyForces(board.current());
    EXPECT_EQ(shared::detail::sequence(1).load(), after) << "nothing written when nobody wrote since";
}

TEST_F(Forces, AStructOrAnArrayAsAWholeIsRefusedNamingItsMembers) {
    auto whole = variables::findLeaf(layout, "knu.Robot.joints[1]");
    ASSERT_FALSE(whole.ok());
    EXPECT_NE(whole.error().message.find("is a struct or an array: give one of its members"), std::string::npos)
        << whole.error().message;
    EXPECT_NE(whole.error().message.find("knu.Robot.joints[1].x"), std::string::npos) << whole.error().message;
    auto array = variables::findLeaf(layout, "knu.Robot.joints");
    ASSERT_FALSE(array.ok());
    EXPECT_NE(array.error().message.find("knu.Robot.joints[0].x"), std::string::npos) << array.error().message;
}

TEST_F(Forces, ATableIsFreedOnlyOnceEveryReaderTookANewerOne) {
    dispatch::ForceBoard board;
    const dispatch::ForceTable *first = board.current();
    EXPECT_EQ(first->generation, 1u);
    EXPECT_TRUE(first->leaves.empty());
    const uint64_t second = board.publish({forced("knu.Robot.tick", 1)});
    const uint64_t third = board.publish({forced("knu.Robot.tick", 2)});
    EXPECT_EQ(board.current()->generation, third);
    EXPECT_EQ(board.retired(), 2u);
    board.reclaim(0);  // a reader that took no table yet may read any
    EXPECT_EQ(board.retired(), 2u);
    board.reclaim(second);  // the slowest reader took the second table: the first is free
    EXPECT_EQ(board.retired(), 1u);
    board.reclaim(third);
    EXPECT_EQ(board.retired(), 0u);
    EXPECT_EQ(board.current()->leaves.size(), 1u);
}
