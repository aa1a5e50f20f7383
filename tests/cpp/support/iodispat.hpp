// iodispat.hpp -- what the I/O dispatcher's tests share (test_ioconfig, test_iodispat,
// test_iodispat_can): the plc-robot cell's shared-variable segment, made once per executable as
// irpd makes it before loading modules, and small helpers around its variables and refusals.
#pragma once

#include "subprocess.hpp"
#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"

#include <indurop/generated.h>  // the plc-robot cell's variables (PLC_ROBOT::...)

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdint>
#include <fstream>
#include <memory>
#include <string>
#include <utility>

namespace testing_support {

// ---- one segment for the executable, as irpd makes it before loading modules -------------------
class Segment : public ::testing::Environment {
public:
    void SetUp() override {
        auto layout = irp::variables::readLayout(std::string(BUILD_ROOT) + "/sets/plc-robot/layout.json");
        ASSERT_TRUE(layout.ok()) << layout.error().message;
        auto segment = irp::variables::VariableSegment::create("test-io-" + std::to_string(getpid()), *layout);
        ASSERT_TRUE(segment.ok()) << segment.error().message;
        segment_ = std::make_unique<irp::variables::VariableSegment>(std::move(*segment));
    }
    void TearDown() override { segment_.reset(); }

private:
    std::unique_ptr<irp::variables::VariableSegment> segment_;
};
// Including this header registers the environment, once per executable (an inline variable).
inline const ::testing::Environment *const kSegmentEnvironment = ::testing::AddGlobalTestEnvironment(new Segment);

// Every variable the tests write back to its zero value.
inline void resetVariables() {
    for (int i = 0; i < 6; ++i) {
        PLC_ROBOT::AXIS_IN[i] = PLC_ROBOT::AXIS_IN_t{};
        PLC_ROBOT::AXIS_OUT[i] = PLC_ROBOT::AXIS_OUT_t{};
    }
    PLC_ROBOT::IO_STATUS = PLC_ROBOT::IO_STATUS_t{};
}

inline std::string writeFile(const TempDir &dir, const std::string &name, const std::string &text) {
    const std::string path = (dir.path / name).string();
    std::ofstream(path) << text;
    return path;
}

// The CiA 402 state bits of a statusword.
inline uint16_t state(uint16_t statusword) { return statusword & 0x6F; }

}  // namespace testing_support

// Each of the given parts occurs in the message (a refusal: file:line, the element, what was expected).
#define EXPECT_REFUSED(message, ...)                                                                                   \
    do {                                                                                                               \
        const std::string m = (message);                                                                               \
        for (const char *part : {__VA_ARGS__}) EXPECT_NE(m.find(part), std::string::npos) << m;                        \
    } while (0)
