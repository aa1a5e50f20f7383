// layout_json.hpp -- every shared-memory segment's layout as JSON (`irpd --print-shm-layout`), so
// that readers in other languages take every offset from irpd itself (docs/shared-memory.md).
#pragma once

#include "shm/describe.hpp"

#include <nlohmann/json_fwd.hpp>

namespace irp::shm {

// The description's own format: readers check it before trusting the rest.
inline constexpr int kDescriptionFormat = 1;

// {"format", "byte_order", "segments": {"variables", "stats", "trace", "control"}}.
nlohmann::ordered_json layoutJson();

// One segment's entry of it.
nlohmann::ordered_json segmentJson(const Segment &segment);

}  // namespace irp::shm
