// generation.hpp -- one generation of the running set: what irpd runs between two hot reloads.
//
// A generation is the set (module.xml as parsed, with the periods and priorities changed since),
// its schedule, one Member per module (the loaded library or the process's control slot, its
// stats record) and the executors' tables.  A module kept by a reload is shared between two
// generations: the same ThreadModule, the same process, the same record.
#pragma once

#include "config/module_xml.hpp"
#include "dispatch/dispatcher.hpp"
#include "dispatch/function_calls.hpp"
#include "hosts/thread_module.hpp"
#include "schedule/schedule.hpp"
#include "variables/conversion.hpp"
#include "variables/layout.hpp"

#include <cstdint>
#include <memory>
#include <set>
#include <string>
#include <vector>

namespace irp::reload {

struct Member {
    std::shared_ptr<hosts::ThreadModule> thread;  // thread modules
    std::string sha256;                           // the content of the file it was loaded from
    std::string identity;                         // its loadable code (hosts/module_identity.hpp)
    std::string layout;                           // the layout hash it was built against ("": none)
    std::size_t record = 0;                       // its stats record
    int slot = -1;                                // process modules: their control slot
    bool kept = false;                            // the same instance as in the previous generation
    uint32_t alarm_source = 0;                    // its source in the alarm segment (0: none; 0 is irpd's)
    bool alarm_claimed = false;                   // that source was given to it for this generation
};

struct Generation {
    uint64_t number = 0;  // 1 for the set irpd started with, +1 per swap
    std::string set_id;   // the caller's name for the set (the agent's set store id), may be empty
    config::SetSpec set;
    schedule::Schedule schedule;
    std::vector<Member> members;     // per set index
    std::set<std::string> disabled;  // modules taken out of dispatch by request
    std::unique_ptr<dispatch::Tables> tables;
    // The shared-variable layout it runs on (null: none) and what changed from the generation
    // before; published into the segment before its modules load (docs/hot-reload.md).
    std::shared_ptr<const variables::Layout> layout;
    layouts::Diff variables;             // its `moved`: retyped and not converted
    variables::Conversions conversions;  // retyped and converted at the swap
    // With conversions: the swap's gate (dispatch::SwapGate), whose work converts into the data area.
    std::unique_ptr<dispatch::SwapGate> gate;
    char *conversion_data = nullptr;
    std::vector<std::string> replaced_for_layout;              // running modules the new layout leaves no place for
    bool published = false;                                    // this generation published its layout
    std::shared_ptr<const variables::Layout> previous_layout;  // what undo publishes again
    // The server of calls from processes bound to this generation's exports (null: none).
    std::shared_ptr<dispatch::CallServer> calls;

    // The index of module `name` in the set, or -1.
    int find(const std::string &name) const {
        for (const config::ModuleSpec &m : set.modules)
            if (m.name == name) return m.index;
        return -1;
    }
};

}  // namespace irp::reload
