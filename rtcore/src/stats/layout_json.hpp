// layout_json.hpp -- the stats block's layout as JSON (`irpd --print-stats-layout`), so that
// readers in other languages take every offset from irpd itself instead of copying them.
#pragma once

#include <nlohmann/json_fwd.hpp>

namespace irp::stats {

nlohmann::ordered_json layoutJson();

} // namespace irp::stats
