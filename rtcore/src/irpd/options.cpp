// options.cpp -- getopt_long parsing of irpd's options, with checked numbers.
#include "irpd/options.hpp"

#include "protocol/limits.hpp"

#include <getopt.h>

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cctype>
#include <cstring>

namespace irp::daemon {
namespace {

enum Flag {
    kConfig = 1000,
    kPrintSchedule,
    kJson,
    kDuration,
    kStatsJson,
    kInstance,
    kMinBasic,
    kCpu,
    kRtPriority,
    kNoRt,
    kPolicy,
    kMaxCatchup,
    kHelp,
    kVersion,
    kShmLayout,
    kLayout,
    kControlSocket,
    kModuleCache,
    kStateDir,
    kUser,
    kGroup,
    kVarHeadroom,
    kModuleRecords,
    kProcessSlots,
    kRetainInterval,
};

const option kOptions[] = {
    {"config", required_argument, nullptr, kConfig},
    {"print-schedule", no_argument, nullptr, kPrintSchedule},
    {"json", no_argument, nullptr, kJson},
    {"duration", required_argument, nullptr, kDuration},
    {"stats-json", required_argument, nullptr, kStatsJson},
    {"instance", required_argument, nullptr, kInstance},
    {"min-basic-period", required_argument, nullptr, kMinBasic},
    {"cpu", required_argument, nullptr, kCpu},
    {"rt-priority", required_argument, nullptr, kRtPriority},
    {"no-rt", no_argument, nullptr, kNoRt},
    {"overrun-policy", required_argument, nullptr, kPolicy},
    {"max-catchup", required_argument, nullptr, kMaxCatchup},
    {"help", no_argument, nullptr, kHelp},
    {"version", no_argument, nullptr, kVersion},
    {"print-shm-layout", no_argument, nullptr, kShmLayout},
    {"layout", required_argument, nullptr, kLayout},
    {"control-socket", required_argument, nullptr, kControlSocket},
    {"module-cache", required_argument, nullptr, kModuleCache},
    {"state-dir", required_argument, nullptr, kStateDir},
    {"user", required_argument, nullptr, kUser},
    {"group", required_argument, nullptr, kGroup},
    {"var-headroom", required_argument, nullptr, kVarHeadroom},
    {"module-records", required_argument, nullptr, kModuleRecords},
    {"process-slots", required_argument, nullptr, kProcessSlots},
    {"retain-interval", required_argument, nullptr, kRetainInterval},
    {nullptr, 0, nullptr, 0},
};

Result<int64_t> integer(const char *option, const char *text, int64_t min, int64_t max) {
    int64_t v = 0;
    const char *end = text + std::strlen(text);
    auto [p, ec] = std::from_chars(text, end, v);
    if (ec != std::errc() || p != end || v < min || v > max)
        return Error{std::string("--") + option + ": '" + text + "' is not an integer from " + std::to_string(min) +
                     " to " + std::to_string(max)};
    return v;
}

}  // namespace

std::string usage() {
    return R"(usage: irpd --config FILE.xml [options]

Runs the module set described by FILE.xml (the paper's module.xml) on a strict period.

  --config FILE.xml        the set to run
  --print-schedule         print the slot table (basic/macro period, modules per slot) and exit
  --json                   with --print-schedule: print it as JSON
  --duration S             run S seconds of the time grid, then stop (default: until SIGINT/SIGTERM)
  --stats-json FILE        on exit, write per-module and dispatcher timing figures to FILE
  --instance NAME          names the shared memory (/indurop.NAME.stats, /indurop.NAME.vars);
                           default "default"
  --layout FILE.json       the set's shared-variable layout (glbc's layout.json), instead of the
                           <layout> of module.xml
  --var-headroom SIZE      room in the shared-variable segment for variables added by online
                           changes: bytes of data (K, M, G suffixes; default 1M); the locks
                           (one per 256 bytes, at least 256) and the layout text grow with it
  --module-records N       stats records for modules, old and new at once during a hot reload
                           (default: the larger of 256 and twice the first set's modules)
  --process-slots N        control slots for process modules (default: the larger of 16 and the
                           first set's process modules)
  --module-cache DIR       where thread modules are loaded from: copies named after their content's
                           SHA-256, so a hot reload runs a changed file's new code (default
                           /tmp/indurop-<uid>-<instance>-modules, mode 0700)
  --min-basic-period NS    refuse sets whose basic period is shorter (default )" +
           std::to_string(protocol::kMinBasicPeriodNs) + R"()
  --cpu N                  CPU of the main dispatcher thread (default: the last one)
  --rt-priority N          SCHED_FIFO priority of the main dispatcher, 1..99 (default 80)
  --no-rt                  do not ask for SCHED_FIFO or lock memory (development only)
  --overrun-policy P       catch-up (default) or skip: what to do with slots that are due
                           a whole basic period late
  --max-catchup NS         catch-up: largest backlog run back to back before skipping
                           (default 100000000)
  --control-socket PATH    serve the control protocol (docs/control-protocol.md) on this Unix
                           socket (mode 0660)
  --state-dir DIR          where a crash record is left for the next start (mode 0750; default
                           /var/lib/indurop/irpd; see docs/supervision.md); also where the
                           values of RETAIN and PERSISTENT variables are kept (docs/retain.md)
  --retain-interval MS     save changed RETAIN and PERSISTENT values at most once per MS
                           milliseconds, 10 to 3600000 (default 1000), and at stop
  --user USER              after start, run as USER keeping only CAP_SYS_NICE and CAP_IPC_LOCK
                           (irpd must start as root); shared memory and the control socket
                           belong to USER and its group, mode 0660
  --group GROUP            with --user: the group instead of USER's primary group
  --print-shm-layout       print the layout of every shared-memory segment (fields, offsets,
                           types, meanings) as JSON and exit (docs/shared-memory.md)
  --help, --version

Exit status: 0 after a clean stop, 2 when the set is refused (the message names file:line
and the field), 1 on other failures.
)";
}

Result<Options> parseOptions(int argc, char **argv) {
    Options o;
    optind = 1;
    opterr = 0;
    for (;;) {
        int index = 0;
        int c = getopt_long(argc, argv, ":", kOptions, &index);
        if (c == -1) break;
        const char *name = c >= kConfig && c <= kControlSocket ? kOptions[c - kConfig].name : "";
        switch (c) {
        case kConfig: o.config = optarg; break;
        case kPrintSchedule: o.print_schedule = true; break;
        case kJson: o.json = true; break;
        case kDuration: {
            char *end = nullptr;
            double v = std::strtod(optarg, &end);
            if (!end || *end || !std::isfinite(v) || v <= 0 || v > 1e7)
                return Error{std::string("--duration: '") + optarg + "' is not a positive number of seconds"};
            o.duration_s = v;
            break;
        }
        case kStatsJson: o.stats_json = optarg; break;
        case kModuleRecords: {
            auto v = integer("module-records", optarg, 1, 100'000);
            if (!v) return v.error();
            o.module_records = static_cast<std::size_t>(*v);
            break;
        }
        case kProcessSlots: {
            auto v = integer("process-slots", optarg, 1, 4096);
            if (!v) return v.error();
            o.process_slots = static_cast<uint32_t>(*v);
            break;
        }
        case kVarHeadroom: {
            char *end = nullptr;
            const unsigned long long v = std::strtoull(optarg, &end, 10);
            uint64_t unit = 1;
            if (end && (*end == 'K' || *end == 'k'))
                unit = 1ull << 10, ++end;
            else if (end && (*end == 'M' || *end == 'm'))
                unit = 1ull << 20, ++end;
            else if (end && (*end == 'G' || *end == 'g'))
                unit = 1ull << 30, ++end;
            if (!end || *end || end == optarg || !std::isdigit(static_cast<unsigned char>(optarg[0])) ||
                v * unit > (1ull << 30))
                return Error{std::string("--var-headroom: '") + optarg +
                             "' is not a size from 0 to 1G (bytes, or with K, M or G)"};
            o.var_headroom = v * unit;
            break;
        }
        case kInstance: {
            o.instance = optarg;
            bool ok = !o.instance.empty() && o.instance.size() <= 64;
            for (char ch : o.instance)
                ok = ok && (std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-');
            if (!ok) return Error{"--instance: '" + o.instance + "' must be 1-64 letters, digits, '_' or '-'"};
            break;
        }
        case kMinBasic: {
            auto v = integer(name, optarg, 1000, 1'000'000'000);
            if (!v) return v.error();
            o.limits.min_basic_ns = *v;
            break;
        }
        case kCpu: {
            auto v = integer(name, optarg, 0, 4095);
            if (!v) return v.error();
            o.dispatcher.cpu = static_cast<int>(*v);
            break;
        }
        case kRtPriority: {
            auto v = integer(name, optarg, 1, 99);
            if (!v) return v.error();
            o.dispatcher.rt_priority = static_cast<int>(*v);
            break;
        }
        case kNoRt: o.dispatcher.realtime = false; break;
        case kPolicy:
            if (std::strcmp(optarg, "catch-up") == 0)
                o.dispatcher.policy = dispatch::OverrunPolicy::CatchUp;
            else if (std::strcmp(optarg, "skip") == 0)
                o.dispatcher.policy = dispatch::OverrunPolicy::Skip;
            else
                return Error{std::string("--overrun-policy: '") + optarg + "'; expected catch-up or skip"};
            break;
        case kMaxCatchup: {
            auto v = integer(name, optarg, 0, 60'000'000'000);
            if (!v) return v.error();
            o.dispatcher.max_catchup_ns = *v;
            break;
        }
        case kHelp: o.help = true; break;
        case kVersion: o.version = true; break;
        case kShmLayout: o.print_shm_layout = true; break;
        case kLayout: o.layout = optarg; break;
        case kModuleCache: o.module_cache = optarg; break;
        case kControlSocket: o.control_socket = optarg; break;
        case kRetainInterval: {
            auto v = integer("retain-interval", optarg, 10, 3'600'000);
            if (!v) return v.error();
            o.retain_interval_ns = *v * 1'000'000;
            break;
        }
        case kStateDir:
            if (!*optarg) return Error{"--state-dir: the folder is empty"};
            o.state_dir = optarg;
            break;
        case kUser:
            if (!*optarg) return Error{"--user: the user name is empty"};
            o.user = optarg;
            break;
        case kGroup:
            if (!*optarg) return Error{"--group: the group name is empty"};
            o.group = optarg;
            break;
        case ':': return Error{std::string("option ") + argv[optind - 1] + " needs a value"};
        default: return Error{std::string("unknown option ") + argv[optind - 1]};
        }
    }
    if (optind < argc) return Error{std::string("unexpected argument '") + argv[optind] + "'"};
    if (o.help || o.version || o.print_shm_layout) return o;
    if (o.config.empty()) return Error{"--config FILE.xml is required"};
    if (o.json && !o.print_schedule) return Error{"--json goes with --print-schedule"};
    if (!o.group.empty() && o.user.empty()) return Error{"--group goes with --user"};
    return o;
}

}  // namespace irp::daemon
