// test_shared_variables.cpp -- the paper's shared variables (Figure 3, plus the `joint` of Figures 7
// and 8) in a real segment: ordinary syntax, offsets as in layout.json, no torn struct with writers
// in threads and in another process, atomic compound assignment, a writer that dies holding a lock.
#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"

#include <indurop/generated.h>
#include <indurop/indurop.h>

#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <thread>
#include <vector>

using namespace irp;

namespace {

const std::string kLayout = std::string(BUILD_ROOT) + "/sets/paper-fig1/layout.json";

// One segment for the whole suite, made this process's segment (as irpd does before loading modules).
class Segment : public ::testing::Environment {
public:
    void SetUp() override {
        auto layout = variables::readLayout(kLayout);
        ASSERT_TRUE(layout.ok()) << layout.error().message;
        layout_ = nlohmann::json::parse(layout->text);
        auto segment = variables::VariableSegment::create("test-vars-" + std::to_string(getpid()), *layout);
        ASSERT_TRUE(segment.ok()) << segment.error().message;
        segment_ = std::make_unique<variables::VariableSegment>(std::move(*segment));
    }
    void TearDown() override { segment_.reset(); }
    static nlohmann::json layout_;
    static std::unique_ptr<variables::VariableSegment> segment_;
};
nlohmann::json Segment::layout_;
std::unique_ptr<variables::VariableSegment> Segment::segment_;
const auto *const kEnvironment = ::testing::AddGlobalTestEnvironment(new Segment);

uint64_t leafOffset(const std::string &path) {
    for (const auto &leaf : Segment::layout_["leaves"])
        if (leaf["path"] == path) return leaf["offset"];
    ADD_FAILURE() << "no leaf " << path;
    return 0;
}

using knu::Robot::joints;
using knu::Robot::joints_t;
using knu::Robot::tick;

}  // namespace

TEST(SharedVariables, ScalarsReadAndWriteLikeGlobals) {
    tick = 5;
    tick = tick + 10;  // Figure 5
    EXPECT_EQ(tick, 15u);
    tick += 10;
    ++tick;
    EXPECT_EQ(tick++, 26u);
    EXPECT_EQ(static_cast<uint32_t>(tick), 27u);
    INDUROP_TYPEDEF(tick)::value_type copy = tick;
    static_assert(std::is_same_v<decltype(copy), uint32_t>);
}

TEST(SharedVariables, StructsAndArraysReadAndWriteWhole) {
    INDUROP_TYPEDEF(joints)::value_type v = joints[0];  // Figure 4
    static_assert(std::is_same_v<decltype(v), joints_t>);
    v = joints_t{1.5, 2.5, 3.5};
    joints[3] = v;  // Figure 5
    joints_t back = joints[3];
    EXPECT_EQ(back.x, 1.5);
    EXPECT_EQ(back.y, 2.5);
    EXPECT_EQ(back.z, 3.5);
    joints[3].y = 7;  // one member
    EXPECT_EQ(joints[3].y, 7.0);
    EXPECT_EQ(static_cast<joints_t>(joints[3]).x, 1.5);
    joints[4] = joints[3];  // shared to shared copies the value
    EXPECT_EQ(joints[4].y, 7.0);
    joint[0].x = 180;  // Figure 7's variable, global
    EXPECT_GE(joint[0].x, 180);
}

TEST(SharedVariables, ValuesLandAtTheLayoutsOffsets) {
    joints[3].y = 42.25;
    tick = 0xdeadbeef;
    joint[1].y = -3.0;
    auto at = [](const std::string &path) { return indurop_shared_data + leafOffset(path); };
    EXPECT_EQ(*reinterpret_cast<const double *>(at("knu.Robot.joints[3].y")), 42.25);
    EXPECT_EQ(*reinterpret_cast<const uint32_t *>(at("knu.Robot.tick")), 0xdeadbeefu);
    EXPECT_EQ(*reinterpret_cast<const double *>(at("joint[1].y")), -3.0);
    EXPECT_EQ(leafOffset("knu.Robot.joints[3].y"), joints[3].y.offset());
}

TEST(SharedVariables, CompoundAssignmentIsAtomicAcrossThreads) {
    tick = 0;
    std::vector<std::thread> threads;
    for (int i = 0; i < 4; ++i)
        threads.emplace_back([] {
            for (int k = 0; k < 50000; ++k) tick += 1;
        });
    for (auto &t : threads) t.join();
    EXPECT_EQ(tick, 200000u);
}

TEST(SharedVariables, NoTornStructWithWritersInThreadsAndInAnotherProcess) {
    joints[0] = joints_t{0, 0, 0};
    std::atomic<bool> stop{false};
    // A writer in another process (fork: same segment mapping) writes x == y == z < 0 ...
    pid_t child = fork();
    if (child == 0) {
        for (int k = 1; k < 200000; ++k) joints[0] = joints_t{-1.0 * k, -1.0 * k, -1.0 * k};
        _exit(0);
    }
    // ... two writer threads x == y == z > 0 ...
    std::vector<std::thread> writers;
    for (int w = 0; w < 2; ++w)
        writers.emplace_back([&stop, w] {
            for (double k = 1; !stop.load(); ++k) joints[0] = joints_t{k + w * 1e9, k + w * 1e9, k + w * 1e9};
        });
    // ... and a reader never sees a mix.
    uint64_t torn = 0, reads = 0;
    int status = 0;
    while (waitpid(child, &status, WNOHANG) == 0 || reads < 100000) {
        joints_t v = joints[0];
        ++reads;
        if (v.x != v.y || v.y != v.z) ++torn;
    }
    stop = true;
    for (auto &t : writers) t.join();
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    EXPECT_EQ(torn, 0u) << "of " << reads << " reads";
    EXPECT_GT(reads, 0u);
}

TEST(SharedVariables, AReaderWaitsOutAStalledWriterAndSeesOneWholeValue) {
    joints[2] = joints_t{1, 1, 1};
    std::atomic<bool> inside{false};
    std::thread writer([&] {
        // A writer stalled half-way (as if preempted): the reader must not see x = 2, y = 1.
        shared::detail::writeExclusive(joints[2].lockIndex(), [&] {
            auto *p = reinterpret_cast<double *>(joints[2].address());
            __atomic_store_n(reinterpret_cast<uint64_t *>(&p[0]), std::bit_cast<uint64_t>(2.0), __ATOMIC_RELAXED);
            inside = true;
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
            __atomic_store_n(reinterpret_cast<uint64_t *>(&p[1]), std::bit_cast<uint64_t>(2.0), __ATOMIC_RELAXED);
            __atomic_store_n(reinterpret_cast<uint64_t *>(&p[2]), std::bit_cast<uint64_t>(2.0), __ATOMIC_RELAXED);
        });
    });
    while (!inside) std::this_thread::yield();
    joints_t v = joints[2];  // spins, then takes the PI lock: returns after the writer
    writer.join();
    EXPECT_EQ(v.x, 2.0);
    EXPECT_EQ(v.y, 2.0);
    EXPECT_EQ(v.z, 2.0);
}

TEST(SharedVariables, AWriterThatDiedHoldingTheLockIsRepaired) {
    const uint64_t before = shared::repairedLocks();
    const uint32_t lock = joints[0].lockIndex();
    pid_t child = fork();
    if (child == 0) {
        shared::lockVariable(lock);
        std::atomic_ref<uint32_t>(indurop_shared_locks[lock].seq).fetch_add(1);  // died mid-write: odd
        _exit(0);
    }
    int status = 0;
    waitpid(child, &status, 0);
    joints[0] = joints_t{5, 6, 7};  // takes the dead owner's lock
    EXPECT_EQ(shared::repairedLocks(), before + 1);
    EXPECT_EQ(std::atomic_ref<uint32_t>(indurop_shared_locks[lock].seq).load() % 2, 0u);
    joints_t v = joints[0];
    EXPECT_EQ(v.z, 7.0);
}

TEST(SharedVariables, TheSegmentCarriesItsLayout) {
    EXPECT_EQ(shared::layoutHash(), Segment::layout_["hash"].get<std::string>().c_str());
    EXPECT_EQ(nlohmann::json::parse(shared::layoutText())["hash"], Segment::layout_["hash"]);
    EXPECT_EQ(shared::layoutHash(), std::string(INDUROP_LAYOUT_HASH));  // the header this test was built with
}
