// fuzz_segment.hpp -- for the fuzz targets that write shared variables: one segment of the
// plc-robot cell's layout (cell.glb) for the whole run, made as irpd makes it, removed at exit.
#pragma once

#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include <unistd.h>

namespace fuzz {

// The layout's text (layout.json), parsed by irpd's own reader; the segment stays until exit.
inline const irp::variables::Layout &plcRobotSegment(const char *target) {
    static std::unique_ptr<irp::variables::Layout> layout;
    static std::unique_ptr<irp::variables::VariableSegment> segment;
    if (layout) return *layout;
    auto read = irp::variables::readLayout(PLC_ROBOT_LAYOUT);
    if (!read) {
        std::fprintf(stderr, "%s: %s\n", target, read.error().message.c_str());
        std::exit(2);
    }
    auto made = irp::variables::VariableSegment::create(std::string(target) + "-" + std::to_string(getpid()), *read);
    if (!made) {
        std::fprintf(stderr, "%s: %s\n", target, made.error().message.c_str());
        std::exit(2);
    }
    layout = std::make_unique<irp::variables::Layout>(std::move(*read));
    segment = std::make_unique<irp::variables::VariableSegment>(std::move(*made));
    std::atexit([] { segment.reset(); });
    return *layout;
}

}  // namespace fuzz
