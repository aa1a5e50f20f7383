// alarms.cpp -- libindurop's alarm calls (irp::raiseAlarm, irp::clearAlarm, irp::declareAlarm)
// and the registry of declarations, following the protocol of <indurop/alarms.h>.
//
// Raising and clearing run on the RT thread: no allocation, no lock, no syscall but
// clock_gettime (vDSO).  A call finds its source through a thread-local index (a thread module:
// set by the dispatcher before run() and condition(), by the host before initialize() and
// start()) or the process's own (a process module: INDUROP_ALARM_SOURCE), and the segment
// through one pointer (irpd adopts the segment it created; a process maps the one INDUROP_ALARMS
// names when this library loads, before main()).  Declarations happen in initialize()/start():
// a mutex and a map are fine there.
#include <indurop/alarms.h>
#include <indurop/indurop.h>
#include <indurop/property.h>

#include "alarm_rules.hpp"
#include "runtime.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace irp {
namespace {

std::atomic<indurop_alarm_header *> g_segment{nullptr};
// A process module's source (every thread of the process); none in irpd.
uint32_t g_process_source = runtime::kNoAlarmSource;
// A thread module's source on this thread.  Trivial and constant-initialized: no allocation and
// no initializer call on a thread's first access.
thread_local uint32_t t_source = runtime::kNoAlarmSource;

constexpr int64_t kSecondNs = 1'000'000'000;

template <class T>
std::atomic_ref<T> atomic(T &field) noexcept {
    return std::atomic_ref<T>(field);
}

void bump(uint64_t &counter) noexcept { atomic(counter).fetch_add(1, std::memory_order_relaxed); }

indurop_alarm_source *sourceOf(indurop_alarm_header *h, uint32_t source) noexcept {
    if (!h || source >= h->source_max) return nullptr;
    return reinterpret_cast<indurop_alarm_source *>(reinterpret_cast<char *>(h) + h->sources_offset) + source;
}

uint32_t currentSource() noexcept { return t_source != runtime::kNoAlarmSource ? t_source : g_process_source; }

int64_t realtimeNs() noexcept {
    timespec ts{};
    clock_gettime(CLOCK_REALTIME, &ts);
    return int64_t{ts.tv_sec} * kSecondNs + ts.tv_nsec;
}

// One more record in the source's second?  The second begins with the first record after the
// last one ended (or when the clock went back).  Writers racing at a second's turn may let one or
// two more through; one writer is held to the limit exactly.
bool withinRate(indurop_alarm_source &s, uint32_t limit, int64_t now) noexcept {
    auto window = atomic(s.window_ns);
    int64_t began = window.load(std::memory_order_acquire);
    if ((now - began >= kSecondNs || now < began) &&
        window.compare_exchange_strong(began, now, std::memory_order_acq_rel))
        atomic(s.window_count).store(0, std::memory_order_relaxed);
    return atomic(s.window_count).fetch_add(1, std::memory_order_relaxed) < limit;
}

// The detail text as a record keeps it: at most INDUROP_ALARM_TEXT_CHARS - 1 bytes, cut before a
// UTF-8 sequence rather than inside one.  Returns the bytes kept; `cut` when some were not.
std::size_t keptLength(const char *detail, bool &cut) noexcept {
    constexpr std::size_t kMax = INDUROP_ALARM_TEXT_CHARS - 1;
    std::size_t n = detail ? strnlen(detail, kMax + 1) : 0;
    cut = n > kMax;
    if (cut)
        for (n = kMax; n > 0 && (static_cast<unsigned char>(detail[n]) & 0xC0) == 0x80;) --n;
    return n;
}

struct Transition {
    uint32_t source;
    uint32_t id;
    uint8_t action;
    uint8_t severity;
    uint16_t flags;
    const char *detail;
    double value;
};

// Claims the next sequence number and writes the record there, unless its slot is held by a
// writer a lap apart (then it counts a collision).  True when written.
bool writeRecord(indurop_alarm_header *h, indurop_alarm_source &src, const Transition &t, int64_t time_ns) noexcept {
    const uint64_t capacity = h->capacity;
    const uint64_t s = atomic(h->head).fetch_add(1, std::memory_order_acq_rel) + 1;
    auto *records = reinterpret_cast<indurop_alarm_record *>(reinterpret_cast<char *>(h) + h->records_offset);
    indurop_alarm_record &r = records[s & (capacity - 1)];
    auto seq = atomic(r.seq);
    const uint64_t lap_before = s > capacity ? s - capacity : 0;
    uint64_t was = seq.load(std::memory_order_relaxed);
    do {
        // 0 after the first lap: a writer is in it (or died there); later than s - capacity: a
        // writer of a later lap took it already.
        if (was > lap_before || (was == 0 && lap_before != 0)) {
            bump(src.collided);
            return false;
        }
    } while (!seq.compare_exchange_weak(was, 0, std::memory_order_acq_rel, std::memory_order_relaxed));
    std::atomic_thread_fence(std::memory_order_release);  // "being written" is seen before any byte below
    bool cut = false;
    const std::size_t n = keptLength(t.detail, cut);
    r.time_ns = time_ns;
    r.cycle = cycle().count;
    r.source_generation = atomic(src.generation).load(std::memory_order_relaxed);
    r.source = t.source;
    r.id = t.id;
    r.action = t.action;
    r.severity = t.severity;
    r.flags = static_cast<uint16_t>(t.flags | (cut ? INDUROP_ALARM_TRUNCATED : 0u));
    r.reserved0 = 0;
    r.value = t.value;
    if (n) std::memcpy(r.text, t.detail, n);
    std::memset(r.text + n, 0, sizeof r.text - n);
    seq.store(s, std::memory_order_release);
    if (cut) bump(src.truncated);
    bump(src.recorded);
    return true;
}

// raiseAlarm and clearAlarm: <indurop/alarms.h>'s "Raising and clearing", in that order.
bool transition(uint32_t id, bool raise, const char *detail, double value, Severity severity) noexcept {
    indurop_alarm_header *h = g_segment.load(std::memory_order_acquire);
    const uint32_t source = currentSource();
    indurop_alarm_source *src = sourceOf(h, source);
    if (!src) return false;
    if (!alarm_rules::validId(id)) {
        bump(src->bad_ids);
        return false;
    }
    const uint64_t bit = uint64_t{1} << (id % 64);
    auto active = atomic(src->active[id / 64]);
    const uint64_t before =
        raise ? active.fetch_or(bit, std::memory_order_acq_rel) : active.fetch_and(~bit, std::memory_order_acq_rel);
    if (((before & bit) != 0) == raise) return false;  // no change: nothing to write
    uint16_t flags = 0;
    if (!(atomic(src->declared[id / 64]).load(std::memory_order_relaxed) & bit)) {
        flags |= INDUROP_ALARM_UNDECLARED;
        bump(src->undeclared);
    }
    const int64_t now = realtimeNs();
    if (!withinRate(*src, h->rate_limit, now)) {
        bump(src->rate_dropped);
        return false;
    }
    const Transition t{source,
                       id,
                       static_cast<uint8_t>(raise ? INDUROP_ALARM_RAISE : INDUROP_ALARM_CLEAR),
                       static_cast<uint8_t>(raise ? severity : Severity::Declared),
                       flags,
                       raise ? detail : nullptr,
                       raise ? value : 0.0};
    return writeRecord(h, *src, t, now);
}

// ---- a process module's segment ----------------------------------------------------------------

// Maps INDUROP_ALARMS read-write and takes INDUROP_ALARM_SOURCE; "" on success, else why not.
std::string mapFromEnvironment(const char *name, const char *source_text) {
    char *end = nullptr;
    errno = 0;
    const unsigned long source = std::strtoul(source_text ? source_text : "", &end, 10);
    if (!source_text || !*source_text || *end || errno || source >= runtime::kNoAlarmSource)
        return std::string("INDUROP_ALARM_SOURCE is '") + (source_text ? source_text : "(unset)") +
               "', not a source number";
    const int fd = shm_open(name, O_RDWR | O_CLOEXEC, 0);
    if (fd < 0) return std::string(name) + ": " + std::strerror(errno);
    struct stat st {};
    if (fstat(fd, &st) != 0 || static_cast<std::size_t>(st.st_size) < sizeof(indurop_alarm_header)) {
        close(fd);
        return std::string(name) + ": too small to be an alarm segment";
    }
    const auto size = static_cast<std::size_t>(st.st_size);
    void *p = mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    const int e = errno;
    close(fd);
    if (p == MAP_FAILED) return std::string(name) + ": mmap: " + std::strerror(e);
    auto *h = static_cast<indurop_alarm_header *>(p);
    std::string problem;
    if (h->magic != INDUROP_ALARMS_MAGIC || h->version != INDUROP_ALARMS_VERSION)
        problem = "not an alarm segment of this libindurop's version";
    else if (h->record_size != sizeof(indurop_alarm_record) || h->source_size != sizeof(indurop_alarm_source) ||
             h->total_size > size || h->capacity == 0 || (h->capacity & (h->capacity - 1)))
        problem = "laid out otherwise than this libindurop expects";
    else if (source >= h->source_max)
        problem = "source " + std::to_string(source) + " out of range (" + std::to_string(h->source_max) + ")";
    if (!problem.empty()) {
        munmap(p, size);
        return std::string(name) + ": " + problem;
    }
    g_process_source = static_cast<uint32_t>(source);
    g_segment.store(h, std::memory_order_release);
    return {};
}

// Before main(): a process module raises alarms from its first line on, with no syscall then.
__attribute__((constructor)) void attachAlarmsFromEnvironment() {
    const char *name = std::getenv("INDUROP_ALARMS");
    if (!name || !*name) return;
    if (const std::string why = mapFromEnvironment(name, std::getenv("INDUROP_ALARM_SOURCE")); !why.empty()) {
        std::fprintf(stderr, "indurop: alarms: %s; irp::raiseAlarm and irp::clearAlarm do nothing\n", why.c_str());
        std::fflush(stderr);
    }
}

// ---- declarations ------------------------------------------------------------------------------

std::mutex g_declarations_mutex;
std::map<uint64_t, std::vector<runtime::AlarmDeclaration>> g_declarations;  // by module instance

}  // namespace

bool raiseAlarm(uint32_t id, const char *detail, double value, Severity severity) noexcept {
    if (static_cast<uint8_t>(severity) > static_cast<uint8_t>(Severity::Critical)) severity = Severity::Declared;
    return transition(id, true, detail, value, severity);
}

bool clearAlarm(uint32_t id) noexcept { return transition(id, false, nullptr, 0, Severity::Declared); }

void declareAlarm(uint32_t id, Severity severity, const char *text) {
    const std::string what = "irp::declareAlarm(" + std::to_string(id) + "): ";
    const uint64_t instance = runtime::currentModuleInstance();
    if (!instance)
        throw PropertyError(what + (g_process_source != runtime::kNoAlarmSource
                                        ? "a process module declares its alarms in module.xml (<alarm id=\"" +
                                              std::to_string(id) + "\" severity=\"...\">text</alarm>)"
                                        : "call it from a thread module's initialize() or start()"));
    if (!alarm_rules::validId(id))
        throw PropertyError(what + "alarm ids run from 1 to " + std::to_string(INDUROP_ALARM_ID_MAX));
    if (severity == Severity::Declared) severity = Severity::Medium;  // the default, as in module.xml
    if (static_cast<uint8_t>(severity) > static_cast<uint8_t>(Severity::Critical))
        throw PropertyError(what + "severity " + std::to_string(static_cast<int>(severity)) +
                            " is none of Low, Medium, High, Critical");
    const std::string line = text ? text : "";
    if (const std::string problem = alarm_rules::textProblem(line); !problem.empty())
        throw PropertyError(what + problem);
    {
        std::lock_guard lock(g_declarations_mutex);
        std::vector<runtime::AlarmDeclaration> &list = g_declarations[instance];
        auto it = std::find_if(list.begin(), list.end(), [&](const auto &d) { return d.id == id; });
        if (it != list.end()) {
            if (it->text == line && it->severity == severity) return;  // the same declaration again
            throw PropertyError(what + "alarm " + std::to_string(id) + " is declared already " +
                                (it->from_code ? "by the module" : "in module.xml") + " as '" + it->text + "' (" +
                                alarm_rules::severityName(it->severity) + "), not '" + line + "' (" +
                                alarm_rules::severityName(severity) + ")");
        }
        list.push_back({id, severity, line, true});
    }
    // Declared from now on: raising it is not flagged undeclared (irpd keeps the bit at the swap).
    if (indurop_alarm_source *src = sourceOf(g_segment.load(std::memory_order_acquire), currentSource()))
        atomic(src->declared[id / 64]).fetch_or(uint64_t{1} << (id % 64), std::memory_order_acq_rel);
}

namespace runtime {

// irpd: its own segment; a segment INDUROP_ALARMS named in its environment (an irpd started by a
// process module) is not its own, nor any source of a process.
void adoptAlarms(indurop_alarm_header *header) noexcept {
    g_process_source = kNoAlarmSource;
    g_segment.store(header, std::memory_order_release);
}

void setAlarmSource(uint32_t source) noexcept { t_source = source; }
uint32_t *alarmSourceWord() noexcept { return &t_source; }

void declareAlarms(uint64_t instance, std::vector<AlarmDeclaration> declarations) {
    std::lock_guard lock(g_declarations_mutex);
    g_declarations[instance] = std::move(declarations);
}

std::vector<AlarmDeclaration> alarmsOf(uint64_t instance) {
    std::lock_guard lock(g_declarations_mutex);
    auto it = g_declarations.find(instance);
    std::vector<AlarmDeclaration> list = it == g_declarations.end() ? std::vector<AlarmDeclaration>{} : it->second;
    std::sort(list.begin(), list.end(), [](const auto &a, const auto &b) { return a.id < b.id; });
    return list;
}

void dropAlarmsOf(uint64_t instance) {
    std::lock_guard lock(g_declarations_mutex);
    g_declarations.erase(instance);
}

}  // namespace runtime
}  // namespace irp
