// shm_cleanup.cpp -- linked into every C++ test program (indurop_test): when its tests end, the
// shared-memory segments of the irpd instances it named (uniqueInstance(): "test-<its pid>-<n>")
// are removed from /dev/shm.  irpd removes its own when it stops; one a test killed (SIGKILL, a
// Process left running at its end) or that crashed leaves them (docs/shared-memory.md).
#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

#include <gtest/gtest.h>

namespace {

class RemoveLeftSegments : public ::testing::Environment {
public:
    void TearDown() override {
        const std::string mine = "indurop.test-" + std::to_string(getpid()) + "-";
        std::error_code ec;
        for (const auto &entry : std::filesystem::directory_iterator("/dev/shm", ec))
            if (entry.path().filename().string().rfind(mine, 0) == 0) std::filesystem::remove(entry.path(), ec);
    }
};

[[maybe_unused]] ::testing::Environment *const registered = ::testing::AddGlobalTestEnvironment(new RemoveLeftSegments);

}  // namespace
