// retain_store.hpp -- the values of RETAIN and PERSISTENT shared variables kept across irpd's
// restarts and power losses (docs/retain.md): two copies in the state folder,
// <instance>.retain.a and .b, written alternately.
//
//   open()    at start, after the segment exists and before any module's initialize(): reads both
//             copies, takes the good one with the higher sequence, restores into the segment what
//             still matches (path, type_id and size; RETAIN only when the program is the same,
//             i.e. the same layout hash); a bad copy is an event and an alarm of irpd's source.
//   start()   once the set is dispatched: the thread "irp@retain" (never an RT thread) compares the
//             retained variables every interval, read with their seqlocks, and writes a copy when
//             one changed or the program did (an online change to another layout).
//   stop()    at the clean stop, after the modules' stop(): the thread ends and a last copy is
//             written if anything changed since.  A start that fails before start() writes nothing
//             (a managed restart's fallback finds the old set's values as they were).
#pragma once

#include "alarms/alarm_segment.hpp"
#include "events/event_log.hpp"
#include "retain/retain_file.hpp"
#include "variables/variable_segment.hpp"

#include <nlohmann/json.hpp>

#include <condition_variable>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace irp::retain {

// irpd's own alarms (source 0, "irpd"), declared by the store.
inline constexpr uint32_t kAlarmCopyBad = 1;      // a copy was torn or corrupt at start
inline constexpr uint32_t kAlarmWriteFailed = 2;  // a copy could not be written

struct Declared {
    uint32_t id;
    const char *severity;  // as the `alarms` command spells it
    const char *text;
};
inline constexpr Declared kAlarms[] = {
    {kAlarmCopyBad, "high",
     "A copy of the retain store was torn or corrupt: the other copy, or the initial values, used"},
    {kAlarmWriteFailed, "high", "The retain store cannot be written: RETAIN and PERSISTENT values may be lost"},
};

class RetainStore {
public:
    struct Settings {
        std::filesystem::path folder;  // the state folder
        std::string instance;
        int64_t interval_ns = 1'000'000'000;
    };

    static std::unique_ptr<RetainStore> open(const Settings &settings, const variables::VariableSegment &vars,
                                             events::EventLog &events, alarms::AlarmSegment *alarms);
    ~RetainStore();  // ends the thread; writes nothing
    RetainStore(const RetainStore &) = delete;
    RetainStore &operator=(const RetainStore &) = delete;

    void start();
    void stop();

    // `status` → `retain`: {file, last_save_ns, sequence, variables, last_error}.
    nlohmann::ordered_json status() const;

    // A retained variable of the running layout.
    struct Retained {
        std::string path, type, type_id, kind;
        uint64_t offset = 0, size = 0;
        uint32_t lock = 0;
    };

private:
    RetainStore(const Settings &settings, const variables::VariableSegment &vars, events::EventLog &events,
                alarms::AlarmSegment *alarms);
    void restore();
    void loop();
    // Writes a copy when a value or the program changed, or a bad copy is still to be replaced.
    void saveIfChanged();
    Snapshot capture();
    void alarm(uint32_t id, bool active, const std::string &detail);

    Settings settings_;
    const variables::VariableSegment &vars_;
    events::EventLog &events_;
    alarms::AlarmSegment *alarms_;
    std::filesystem::path files_[2];
    std::function<void()> before_rename_;  // INDUROP_RETAIN_TEST_PAUSE_MS (a test's hook)

    // The saver's own (the thread, or stop() once it ended).
    std::string layout_hash_;
    std::vector<Retained> retained_;
    Snapshot saved_;        // what the files hold now (the values restored, or written last)
    int next_ = 0;          // the copy written next: never the newest good one
    bool pending_ = false;  // write at the next pass even if nothing changed (a bad copy to replace)
    std::vector<int> bad_;  // copies found bad at start, not yet written anew

    mutable std::mutex mutex_;  // the status, and the thread's stop
    std::condition_variable wake_;
    bool stopping_ = false;
    std::thread thread_;
    std::string status_file_, last_error_;
    int64_t last_save_ns_ = 0;
    uint64_t sequence_ = 0;
    std::size_t count_ = 0;
};

// The retained variables of a layout.json text (those with "retain": "retain" or "persistent").
std::vector<RetainStore::Retained> retainedOf(const std::string &layout_text);

}  // namespace irp::retain
