// retain_store.cpp -- restore at start, the saver thread, the last save at stop (retain_store.hpp).
#include "retain/retain_store.hpp"

#include "osal/atomic_file.hpp"
#include "sdk/runtime.hpp"

#include <indurop/indurop.h>
#include <indurop/shared.h>

#include <pthread.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>

namespace irp::retain {
namespace {

int64_t realtimeNs() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
        .count();
}

// irpd's alarm calls name source 0 on the calling thread while `this` lives.
struct AsIrpd {
    AsIrpd() { runtime::setAlarmSource(alarms::kIrpdSource); }
    ~AsIrpd() { runtime::setAlarmSource(runtime::kNoAlarmSource); }
};

std::string plural(std::size_t n, const std::string &what) {
    return std::to_string(n) + " " + what + (n == 1 ? "" : "s");
}

}  // namespace

std::vector<RetainStore::Retained> retainedOf(const std::string &layout_text) {
    std::vector<RetainStore::Retained> list;
    const nlohmann::json doc = nlohmann::json::parse(layout_text, nullptr, false);
    if (!doc.is_object() || !doc.contains("variables") || !doc["variables"].is_array()) return list;
    for (const nlohmann::json &v : doc["variables"]) {
        const std::string kind = v.value("retain", "");
        if (kind != "retain" && kind != "persistent") continue;
        list.push_back({v.value("path", ""), v.value("type", ""), v.value("type_id", ""), kind,
                        v.value("offset", uint64_t{0}), v.value("size", uint64_t{0}), v.value("lock", uint32_t{0})});
    }
    return list;
}

RetainStore::RetainStore(const Settings &settings, const variables::VariableSegment &vars, events::EventLog &events,
                         alarms::AlarmSegment *alarms)
    : settings_(settings), vars_(vars), events_(events), alarms_(alarms) {
    files_[0] = settings.folder / (settings.instance + ".retain.a");
    files_[1] = settings.folder / (settings.instance + ".retain.b");
    // A test's pause between a copy written and its rename, to kill irpd in the middle of a write
    // (tests/python/retain); unset in production.
    if (const char *ms = std::getenv("INDUROP_RETAIN_TEST_PAUSE_MS"); ms && std::atoi(ms) > 0)
        before_rename_ = [pause = std::chrono::milliseconds(std::atoi(ms))] { std::this_thread::sleep_for(pause); };
}

RetainStore::~RetainStore() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
}

std::unique_ptr<RetainStore> RetainStore::open(const Settings &settings, const variables::VariableSegment &vars,
                                               events::EventLog &events, alarms::AlarmSegment *alarms) {
    std::unique_ptr<RetainStore> store(new RetainStore(settings, vars, events, alarms));
    if (alarms) {
        alarms::Bitmap declared{};
        for (const Declared &d : kAlarms) alarms::setBit(declared, d.id);
        alarms->declare(alarms::kIrpdSource, declared, true);
    }
    store->restore();
    return store;
}

void RetainStore::alarm(uint32_t id, bool active, const std::string &detail) {
    if (!alarms_) return;
    AsIrpd as_irpd;
    if (active)
        irp::raiseAlarm(id, detail.c_str(), 0, irp::Severity::High);
    else
        irp::clearAlarm(id);
}

// The newest good copy into the segment: what matches by path, type_id and size; PERSISTENT
// only when the program changed (another layout hash).
void RetainStore::restore() {
    const auto layout = vars_.layout();
    layout_hash_ = layout->hash;
    retained_ = retainedOf(layout->text);
    Loaded loaded = loadCopies(files_[0], files_[1]);
    for (const auto &[file, why] : loaded.bad) {
        bad_.push_back(file == files_[0] ? 0 : 1);
        const std::string used = loaded.newest ? "the other copy, " + loaded.newest_file.string() + " (sequence " +
                                                     std::to_string(loaded.newest->sequence) + "), is used"
                                               : "no good copy: " + plural(retained_.size(), "retained variable") +
                                                     " start at their initial values";
        events_.add("retain_corrupt", "", file.string() + " is " + why + "; " + used);
        alarm(kAlarmCopyBad, true, file.filename().string() + ": " + why);
    }
    pending_ = !bad_.empty();
    std::size_t restored = 0, skipped = 0;
    const bool same = loaded.newest && loaded.newest->identity == layout_hash_;
    if (loaded.newest) {
        next_ = loaded.newest_file == files_[0] ? 1 : 0;
        sequence_ = loaded.newest->sequence;
        for (const Entry &e : loaded.newest->entries) {
            auto r =
                std::find_if(retained_.begin(), retained_.end(), [&](const Retained &x) { return x.path == e.path; });
            const bool fits = r != retained_.end() && r->type_id == e.type_id && r->size == e.bytes.size();
            if (!fits || (!same && (r->kind != "persistent" || e.kind != "persistent"))) {
                ++skipped;
                continue;
            }
            shared::detail::writeExclusive(r->lock, [&] {
                shared::detail::atomicCopy(indurop_shared_data + r->offset, e.bytes.data(), e.bytes.size());
            });
            ++restored;
        }
        saved_ = std::move(*loaded.newest);
    }
    std::string text;
    if (loaded.newest)
        text = "restored " + std::to_string(restored) + " of " + plural(retained_.size(), "retained variable") +
               " from " + loaded.newest_file.string() + " (sequence " + std::to_string(sequence_) +
               (same ? ", the same program)" : ", saved by another program: PERSISTENT values only)") +
               (skipped ? "; " + std::to_string(skipped) + " saved value(s) not restored" : "");
    else
        text = "no retain store in " + settings_.folder.string() + ": " +
               plural(retained_.size(), "retained variable") + " start at their initial values";
    if (loaded.newest || !retained_.empty()) events_.add("retain", "", text);  // else nothing to say
    std::lock_guard lock(mutex_);
    count_ = retained_.size();
    if (loaded.newest) status_file_ = loaded.newest_file.string();
    sequence_ = saved_.sequence;
}

void RetainStore::start() {
    thread_ = std::thread([this] { loop(); });
}

void RetainStore::loop() {
    pthread_setname_np(pthread_self(), "irp@retain");
    std::unique_lock lock(mutex_);
    while (!wake_.wait_for(lock, std::chrono::nanoseconds(settings_.interval_ns), [this] { return stopping_; })) {
        lock.unlock();
        saveIfChanged();
        lock.lock();
    }
}

void RetainStore::stop() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
    saveIfChanged();
}

Snapshot RetainStore::capture() {
    Snapshot s;
    s.identity = layout_hash_;
    for (const Retained &r : retained_) {
        Entry e{r.path, r.type, r.type_id, r.kind, std::vector<uint8_t>(r.size)};
        shared::detail::readConsistent(
            r.lock, [&] { shared::detail::atomicCopy(e.bytes.data(), indurop_shared_data + r.offset, r.size); });
        s.entries.push_back(std::move(e));
    }
    return s;
}

void RetainStore::saveIfChanged() {
    if (const auto layout = vars_.layout(); layout->hash != layout_hash_) {  // an online change
        layout_hash_ = layout->hash;
        retained_ = retainedOf(layout->text);
        std::lock_guard lock(mutex_);
        count_ = retained_.size();
    }
    if (retained_.empty()) return;  // nothing to keep: the files stay as they are
    Snapshot now = capture();
    if (!pending_ && now.identity == saved_.identity && now.entries == saved_.entries) return;
    now.sequence = saved_.sequence + 1;
    const Status written = osal::writeAtomically(files_[next_], encode(now), before_rename_);
    const std::string error = written ? "" : written.error().message;
    bool told = false;  // the same error as the last write's: said already
    {
        std::lock_guard lock(mutex_);
        told = last_error_ == error;
    }
    if (!told) {  // said before `status` shows it
        if (!written) events_.add("retain_write_failed", "", error);
        alarm(kAlarmWriteFailed, !written, error);
    }
    if (!written) {
        std::lock_guard lock(mutex_);
        last_error_ = error;
        return;
    }
    {
        std::lock_guard lock(mutex_);
        last_error_.clear();
        status_file_ = files_[next_].string();
        last_save_ns_ = realtimeNs();
        sequence_ = now.sequence;
    }
    if (std::erase(bad_, next_) && bad_.empty()) alarm(kAlarmCopyBad, false, "");
    pending_ = !bad_.empty();
    next_ = 1 - next_;
    saved_ = std::move(now);
}

nlohmann::ordered_json RetainStore::status() const {
    std::lock_guard lock(mutex_);
    using json = nlohmann::ordered_json;
    return json{{"file", status_file_.empty() ? json(nullptr) : json(status_file_)},
                {"last_save_ns", last_save_ns_ ? json(last_save_ns_) : json(nullptr)},
                {"sequence", sequence_},
                {"variables", count_},
                {"last_error", last_error_.empty() ? json(nullptr) : json(last_error_)}};
}

}  // namespace irp::retain
