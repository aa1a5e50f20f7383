// schedule.hpp -- the GCD/LCM slot table of the paper's §3 (Table 3).
//
// basic period = GCD of the periods of every periodic module (threads and processes),
// macro period = LCM of them; slot i (at offset i * basic) lists the modules whose period
// divides i * basic, in priority order (lowest <priority> first, ties to the earlier module in
// the file).  The dispatcher walks the slots forever, one per basic period.
#pragma once

#include <indurop/result.hpp>
#include "config/module_xml.hpp"
#include "protocol/limits.hpp"

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace irp::schedule {

// The defaults are the control protocol's (protocol/control.json): the web UI's pre-checks read them too.
struct Limits {
    int64_t min_basic_ns = protocol::kMinBasicPeriodNs;  // a set whose GCD is below this is refused
    std::size_t max_slots =
        static_cast<std::size_t>(protocol::kMaxSlots);  // macro / basic above this is refused (non-harmonic periods)
};

struct Slot {
    std::size_t index = 0;
    int64_t offset_ns = 0;
    std::vector<int> modules;  // indices into SetSpec::modules, in run order
};

struct Schedule {
    int64_t basic_ns = 0;
    int64_t macro_ns = 0;
    std::vector<Slot> slots;
};

Result<Schedule> build(const config::SetSpec &set, const Limits &limits);

// Table 3 as text, with the modules that are outside the table (sporadic, non-real) listed after it.
std::string formatText(const Schedule &schedule, const config::SetSpec &set);

// {"basic_period_ns", "macro_period_ns", "slots": [{"index", "offset_ns", "modules": [names]}],
//  "modules": [{name, moduletype, operationtype, period_ns, deadline_ns, priority, executor}]}
nlohmann::ordered_json toJson(const Schedule &schedule, const config::SetSpec &set);

// "100 us", "1.5 ms", "2 s": a duration for people.
std::string humanDuration(int64_t ns);

}  // namespace irp::schedule
