// irpd.hpp -- what the tests that run the irpd binary share: where it and the paper-fig1 set are,
// and instance names of their own (so that tests never meet on one shared-memory name).
#pragma once

#include <unistd.h>

#include <atomic>
#include <string>

namespace testing_support {

inline const std::string kIrpd = IRPD_PATH;
inline const std::string kFig1 = std::string(BUILD_ROOT) + "/sets/paper-fig1/module.xml";

inline std::string uniqueInstance() {
    static std::atomic<int> n{0};
    return "test-" + std::to_string(getpid()) + "-" + std::to_string(n++);
}

}  // namespace testing_support
