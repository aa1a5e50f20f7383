// options.hpp -- irpd's command line.
#pragma once

#include <indurop/result.hpp>
#include "dispatch/dispatcher.hpp"
#include "schedule/schedule.hpp"

#include <string>

namespace irp::daemon {

struct Options {
    std::string config;                          // --config FILE.xml
    bool print_schedule = false;                 // --print-schedule
    bool json = false;                           // --json (with --print-schedule)
    bool print_shm_layout = false;               // --print-shm-layout
    double duration_s = 0;                       // --duration S (0 = until SIGINT/SIGTERM)
    std::string stats_json;                      // --stats-json FILE
    std::string control_socket;                  // --control-socket PATH ("" = none)
    std::string layout;                          // --layout FILE: the set's layout.json, instead of its <layout>
    uint64_t var_headroom = 1u << 20;            // --var-headroom: data bytes for variables added online
    std::size_t module_records = 0;              // --module-records (0: max(256, 2 x the first set's modules))
    uint32_t process_slots = 0;                  // --process-slots (0: max(16, the first set's processes))
    std::string instance = "default";            // --instance NAME: names the shared memory
    std::string module_cache;                    // --module-cache DIR ("" = /tmp/indurop-<uid>-<instance>-modules)
    std::string state_dir;                       // --state-dir DIR ("" = /var/lib/indurop/irpd, see kDefaultStateDir)
    int64_t retain_interval_ns = 1'000'000'000;  // --retain-interval MS: the retain store's save period
    std::string user, group;                 // --user, --group: switch to them after start (supervise/privileges.hpp)
    schedule::Limits limits;                 // --min-basic-period NS
    dispatch::DispatcherOptions dispatcher;  // --cpu, --rt-priority, --no-rt, --overrun-policy, --max-catchup
    bool help = false;
    bool version = false;
};

// Where crash records live unless --state-dir says otherwise.
inline constexpr const char *kDefaultStateDir = "/var/lib/indurop/irpd";

// Parses argv; the Error says which option is wrong and how.
Result<Options> parseOptions(int argc, char **argv);

std::string usage();

}  // namespace irp::daemon
