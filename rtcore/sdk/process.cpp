// process.cpp -- libindurop's side of process modules: the period handshake through the control
// slot (irp::initPeriodExe, irp::waitPeriod) and shared variables by path (channel::Handle).
#include <indurop/control.h>
#include <indurop/process.h>
#include <indurop/segment.h>
#include <indurop/shared.h>

#include "control_map.hpp"
#include "layouts.hpp"
#include "runtime.hpp"

#include <nlohmann/json.hpp>

#include <dlfcn.h>
#include <fcntl.h>
#include <linux/futex.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <climits>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <mutex>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

// ---- the period handshake ---------------------------------------------------------------------
namespace irp {
namespace {

struct PeriodState {
    indurop_process_slot *slot = nullptr;
    uint32_t last_seq = 0;       // the release_seq this process served last (or saw at start)
    int64_t next_due = 0;        // the slot's next_due_ns at that release: its next release's due time
    bool in_release = false;     // waitPeriod() returned 0 and was not called again yet
    bool stop_returned = false;  // waitPeriod() returned -1 for a stop
};
PeriodState g_period;

using sdk::atomic;
using sdk::monotonicNs;

const char *moduleName() noexcept {
    const char *name = std::getenv("INDUROP_MODULE");
    return name && *name ? name : "?";
}

int refuse(const char *format, ...) __attribute__((format(printf, 1, 2)));
int refuse(const char *format, ...) {
    std::fprintf(stderr, "indurop: module '%s': irp::initPeriodExe(): ", moduleName());
    va_list args;
    va_start(args, format);
    std::vfprintf(stderr, format, args);
    va_end(args);
    std::fputc('\n', stderr);
    std::fflush(stderr);
    return -1;
}

std::string format(const char *format, ...) __attribute__((format(printf, 1, 2)));
std::string format(const char *format, ...) {
    char text[512];
    va_list args;
    va_start(args, format);
    std::vsnprintf(text, sizeof text, format, args);
    va_end(args);
    return text;
}

// Maps the control segment `name` and finds slot `slot_text` in it; an empty `why` on success.
sdk::ControlMap mapSegment(const char *name, const char *slot_text, std::string &why) {
    char *end = nullptr;
    errno = 0;
    const unsigned long index = std::strtoul(slot_text ? slot_text : "", &end, 10);
    if (!slot_text || !*slot_text || *end || errno || index > UINT32_MAX || slot_text[0] == '-') {
        why = format("INDUROP_SLOT is '%s', not a slot number", slot_text ? slot_text : "(unset)");
        return {};
    }
    int fd = shm_open(name, O_RDWR, 0);
    if (fd < 0) {
        why = format("control segment %s: %s", name, std::strerror(errno));
        return {};
    }
    struct stat st {};
    if (fstat(fd, &st) != 0 || static_cast<std::size_t>(st.st_size) < sizeof(indurop_control_header)) {
        close(fd);
        why = format("control segment %s: too small to be one", name);
        return {};
    }
    const auto size = static_cast<std::size_t>(st.st_size);
    void *p = mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    const int e = errno;
    close(fd);
    if (p == MAP_FAILED) {
        why = format("control segment %s: mmap: %s", name, std::strerror(e));
        return {};
    }
    auto *h = static_cast<indurop_control_header *>(p);
    const char *problem = nullptr;
    if (h->magic != INDUROP_CONTROL_MAGIC)
        problem = "not an indurop control segment (bad magic)";
    else if (h->version != INDUROP_CONTROL_VERSION)
        problem = "control segment version differs from this libindurop's";
    else if (h->slot_size != sizeof(indurop_process_slot))
        problem = "slot size differs from this libindurop's";
    else if (h->header_size < sizeof(indurop_control_header) ||
             h->header_size + uint64_t{h->slot_count} * h->slot_size > size)
        problem = "segment shorter than its header says";
    else if (h->function_count && (h->function_size != sizeof(indurop_function_entry) || h->function_offset > size ||
                                   uint64_t{h->function_count} * h->function_size > size - h->function_offset))
        problem = "function table outside the segment, or of another entry size";
    if (problem) {
        const bool ours = h->magic == INDUROP_CONTROL_MAGIC;
        const uint32_t version = h->version, slot_size = h->slot_size;
        munmap(p, size);
        if (!ours)
            why = format("control segment %s: %s", name, problem);
        else
            why =
                format("control segment %s: %s (version %u, slot size %u; this libindurop: version %u, slot size %zu)",
                       name, problem, version, slot_size, INDUROP_CONTROL_VERSION, sizeof(indurop_process_slot));
        return {};
    }
    if (index >= h->slot_count) {
        const uint32_t count = h->slot_count;
        munmap(p, size);
        why = format("INDUROP_SLOT %lu is out of range: control segment %s has %u slots", index, name, count);
        return {};
    }
    auto *slot = reinterpret_cast<indurop_process_slot *>(static_cast<char *>(p) + h->header_size) + index;
    return {h, size, slot};
}

}  // namespace

namespace sdk {

const ControlMap *mapControl(std::string &why) {
    static std::atomic<const ControlMap *> mapped{nullptr};
    static std::mutex mutex;
    static ControlMap map;
    if (const ControlMap *m = mapped.load(std::memory_order_acquire)) return m;
    std::lock_guard<std::mutex> lock(mutex);
    if (const ControlMap *m = mapped.load(std::memory_order_acquire)) return m;
    const char *control = std::getenv("INDUROP_CTL");
    if (!control || !*control) {
        why = "not started by irpd (INDUROP_CTL is not set)";
        return nullptr;
    }
    ControlMap m = mapSegment(control, std::getenv("INDUROP_SLOT"), why);
    if (!m.header) return nullptr;
    map = m;
    mapped.store(&map, std::memory_order_release);
    return &map;
}

}  // namespace sdk

int initPeriodExe() {
    if (g_period.slot) return 0;
    const char *control = std::getenv("INDUROP_CTL");
    if (!control || !*control) {
        std::fprintf(stderr, "indurop: not started by irpd (INDUROP_CTL is not set): irp::initPeriodExe() returns -1, "
                             "irp::waitPeriod() will not wait\n");
        std::fflush(stderr);
        return -1;
    }
    std::string why;
    const sdk::ControlMap *map = sdk::mapControl(why);
    if (!map) return refuse("%s", why.c_str());
    indurop_process_slot *slot = map->slot;
    if (!shared::attachError().empty()) return refuse("%s", shared::attachError().c_str());

    // A process built against another layout must never run: its generated globals would address
    // the wrong bytes.  (indurop_layout_hash is exported by <indurop/generated.h>; process
    // modules are linked with exported symbols.)
    // Built against another layout, it may still run when that layout is one the running one was
    // laid out against and every variable it knows is where it was (layouts::compatible, the same
    // rule irpd applies to thread modules).
    if (const auto *built = static_cast<const char *>(dlsym(RTLD_DEFAULT, "indurop_layout_hash"))) {
        std::string running, text, why;
        shared::layoutCopy(running, text);
        if (running.empty()) {
            why = std::string("it was built against shared-variable layout ") + built +
                  ", but irpd runs no shared variables (the set declares no <layout>)";
        } else if (running != built) {
            std::string problem;
            if (auto model = layouts::parse(text, problem))
                why = layouts::compatible(built, *model);
            else
                why = "the running segment's layout cannot be read: " + problem;
        }
        if (!why.empty()) {
            std::fprintf(stderr, "indurop: module '%s': %s (exit 78)\n", moduleName(), why.c_str());
            std::fflush(stdout);
            std::fflush(stderr);
            _exit(78);
        }
    }

    // Releases from now on are ours: a release that lands between this load and READY is served
    // by the first waitPeriod() at once.
    g_period.last_seq = atomic(slot->release_seq).load(std::memory_order_acquire);
    g_period.next_due = 0;
    atomic(slot->wake_ns).store(0, std::memory_order_relaxed);  // until its first wait: released with a wake
    g_period.in_release = false;
    g_period.stop_returned = false;
    g_period.slot = slot;
    atomic(slot->state).store(INDUROP_PROCESS_READY, std::memory_order_release);
    futex::wakeAll(&slot->state);
    return 0;
}

int waitPeriod() {
    indurop_process_slot *slot = g_period.slot;
    if (!slot) return -1;
    if (g_period.stop_returned) std::exit(0);  // told to stop and came back: leave (see process.h)

    if (g_period.in_release) {
        atomic(slot->done_ns).store(monotonicNs(), std::memory_order_relaxed);
        atomic(slot->state).store(INDUROP_PROCESS_READY, std::memory_order_relaxed);
        atomic(slot->done_seq).store(g_period.last_seq, std::memory_order_release);
        futex::wakeAll(&slot->done_seq);
        g_period.in_release = false;
    }
    // First asleep until the next release's due time, so that this process is runnable when its
    // dispatcher blocks after releasing it (no FUTEX_WAKE needed); then, if that release has not
    // come, until a wake.  Only a moved release_seq returns (control.h).
    int64_t wake = g_period.next_due;
    for (;;) {
        if (atomic(slot->stop_requested).load(std::memory_order_acquire)) {
            g_period.stop_returned = true;
            return -1;
        }
        const uint32_t seq = atomic(slot->release_seq).load(std::memory_order_acquire);
        if (seq != g_period.last_seq) {
            // A release made ahead (control.h) starts at its release_at_ns: asleep until then on
            // its own timer, then claimed, unless irpd took it back first.
            int64_t at = atomic(slot->release_at_ns).load(std::memory_order_acquire);
            if (at == INDUROP_RELEASE_CANCELLED) {  // taken back: done without running
                g_period.last_seq = seq;
                atomic(slot->done_ns).store(monotonicNs(), std::memory_order_relaxed);
                atomic(slot->done_seq).store(seq, std::memory_order_release);
                futex::wakeAll(&slot->done_seq);
                continue;
            }
            const int64_t now = monotonicNs();
            if (at != 0 && now < at) {
                atomic(slot->wake_ns).store(at, std::memory_order_seq_cst);
                // On release_at_ns itself: irpd's compare-and-swap of it (taken back, made a
                // release now) changes the word, so its wake is not lost when it comes first.
                futex::waitUntil(futex::lowWord(&slot->release_at_ns), static_cast<uint32_t>(at), at);
                continue;
            }
            atomic(slot->started_ns).store(now, std::memory_order_relaxed);  // published by the claim
            if (at != 0 && !atomic(slot->release_at_ns).compare_exchange_strong(at, 0, std::memory_order_acq_rel))
                continue;  // irpd took it back meanwhile: read what it made of it
            g_period.last_seq = seq;
            Cycle c{};
            c.count = atomic(slot->cycle).load(std::memory_order_relaxed);
            c.slot = static_cast<uint32_t>(c.count);
            c.planned_ns = atomic(slot->planned_ns).load(std::memory_order_relaxed);
            c.basic_ns = atomic(slot->basic_ns).load(std::memory_order_relaxed);
            g_period.next_due = atomic(slot->next_due_ns).load(std::memory_order_relaxed);
            runtime::setCycle(c);
            atomic(slot->state).store(INDUROP_PROCESS_RUNNING, std::memory_order_relaxed);
            g_period.in_release = true;
            return 0;
        }
        // How this wait ends, announced before it is made; irpd stores release_seq, then reads
        // wake_ns: whichever comes second sees the other's store (both seq_cst).
        atomic(slot->wake_ns).store(wake, std::memory_order_seq_cst);
        if (atomic(slot->release_seq).load(std::memory_order_seq_cst) != seq) continue;
        // A stop request wakes this word too; irpd repeats the wake while it waits, so a stop
        // that lands between the check above and the wait is not lost.
        if (wake) {
            futex::waitUntil(&slot->release_seq, seq, wake);
            wake = 0;  // woken without the release (too early, or a wake): wait on without a timer
        } else {
            futex::wait(&slot->release_seq, seq);
        }
    }
}

}  // namespace irp

// ---- shared variables by path -----------------------------------------------------------------
namespace channel {
namespace {

struct Field {
    std::string name, type;
    uint64_t offset = 0, size = 0;
    std::vector<uint64_t> dims;
};
struct Type {
    uint64_t size = 0;
    std::vector<Field> fields;
};
struct Variable {
    std::string path, ns, name, type;
    uint64_t offset = 0, size = 0;
    std::vector<uint64_t> dims;
    uint32_t lock = 0;
};

// The segment's layout, parsed once per segment and shared by every handle.
struct LayoutIndex {
    const indurop_segment_header *segment = nullptr;
    char hash[INDUROP_LAYOUT_HASH_CHARS + 1] = "";
    std::vector<Variable> variables;
    std::unordered_map<std::string, Type> types;
    uint64_t data_size = 0;
    std::string error;  // the layout text could not be used

    // The same mapping with the same layout: the cached offsets hold.  (A segment replaced by
    // another may be mapped at the same address; its hash tells them apart.)
    bool sameSegment(const indurop_segment_header *other) const noexcept {
        return other == segment && std::memcmp(other->layout_hash, hash, INDUROP_LAYOUT_HASH_CHARS) == 0;
    }
};

void checkDims(const std::vector<uint64_t> &dims, uint64_t size, const std::string &what) {
    uint64_t count = 1;
    for (uint64_t d : dims) {
        if (d == 0) throw std::runtime_error(what + " has a zero dimension");
        count *= d;
    }
    if (size % count)
        throw std::runtime_error(what + ": size " + std::to_string(size) + " does not divide by its dimensions");
}

std::shared_ptr<const LayoutIndex> parseLayout(const indurop_segment_header *segment) {
    auto index = std::make_shared<LayoutIndex>();
    index->segment = segment;
    std::string hash, text;
    irp::shared::layoutCopy(hash, text);  // hash and text of one publication (online change)
    std::memcpy(index->hash, hash.data(), std::min<std::size_t>(hash.size(), INDUROP_LAYOUT_HASH_CHARS));
    try {
        const auto doc = nlohmann::json::parse(text);
        index->data_size = doc.at("data_size").get<uint64_t>();
        for (const auto &[name, t] : doc.at("types").items()) {
            Type type;
            type.size = t.at("size").get<uint64_t>();
            for (const auto &f : t.at("fields")) {
                Field field{f.at("name").get<std::string>(), f.at("type").get<std::string>(),
                            f.at("offset").get<uint64_t>(), f.at("size").get<uint64_t>(),
                            f.at("dims").get<std::vector<uint64_t>>()};
                if (field.offset + field.size > type.size)
                    throw std::runtime_error("field " + name + "." + field.name + " lies outside its struct");
                checkDims(field.dims, field.size, "field " + name + "." + field.name);
                type.fields.push_back(std::move(field));
            }
            index->types.emplace(name, std::move(type));
        }
        for (const auto &v : doc.at("variables")) {
            Variable var{v.at("path").get<std::string>(),
                         v.value("namespace", std::string{}),
                         v.at("name").get<std::string>(),
                         v.at("type").get<std::string>(),
                         v.at("offset").get<uint64_t>(),
                         v.at("size").get<uint64_t>(),
                         v.at("dims").get<std::vector<uint64_t>>(),
                         v.at("lock").get<uint32_t>()};
            if (var.offset + var.size > index->data_size || var.offset + var.size < var.offset)
                throw std::runtime_error("variable " + var.path + " lies outside the data area");
            if (var.lock >= segment->lock_count)
                throw std::runtime_error("variable " + var.path + " names lock " + std::to_string(var.lock));
            checkDims(var.dims, var.size, "variable " + var.path);
            index->variables.push_back(std::move(var));
        }
    } catch (const std::exception &e) {
        index->error = std::string("the shared-variable segment's layout cannot be read: ") + e.what();
        index->variables.clear();
        index->types.clear();
    }
    return index;
}

std::shared_ptr<const LayoutIndex> layoutFor(const indurop_segment_header *segment) {
    static std::mutex mutex;
    static std::shared_ptr<const LayoutIndex> current;
    std::lock_guard<std::mutex> lock(mutex);
    if (!current || !current->sameSegment(segment)) current = parseLayout(segment);
    return current;
}

// Where a path leads in the data area.
struct Target {
    uint64_t offset = 0;
    uint64_t size = 0;
    uint32_t lock = 0;
};

struct StringHash {
    using is_transparent = void;
    std::size_t operator()(std::string_view s) const noexcept { return std::hash<std::string_view>{}(s); }
};

constexpr std::size_t kMaxPathLength = 1024;
constexpr std::size_t kMaxCachedPaths = 65536;

bool boundary(std::string_view path, std::size_t at) { return at == path.size() || path[at] == '.' || path[at] == '['; }

std::string listVariables(const LayoutIndex &index) {
    std::string list;
    std::size_t n = 0;
    for (const Variable &v : index.variables) {
        if (n == 8) return list + ", ...";
        list += (n++ ? ", " : "") + v.path;
    }
    return list.empty() ? "none" : list;
}

// Resolves path against the layout; "" on success, else why not.
std::string resolve(const LayoutIndex &index, std::string_view path, Target &out) {
    if (!index.error.empty()) return index.error;
    const std::string quoted = "'" + std::string(path) + "'";
    if (path.empty()) return "empty path";

    // The top-level variable: its full path, else its name alone when one namespace has it.
    const Variable *var = nullptr;
    std::size_t consumed = 0;
    for (const Variable &v : index.variables)
        if (path.starts_with(v.path) && boundary(path, v.path.size()) && v.path.size() > consumed) {
            var = &v;
            consumed = v.path.size();
        }
    if (!var) {
        std::vector<const Variable *> matches;
        for (const Variable &v : index.variables)
            if (!v.ns.empty() && path.starts_with(v.name) && boundary(path, v.name.size())) matches.push_back(&v);
        if (matches.size() > 1) {
            std::string where;
            for (const Variable *m : matches) where += (where.empty() ? "" : ", ") + m->path;
            return "path " + quoted + " is ambiguous: " + matches[0]->name + " is in several namespaces (" + where +
                   "); write the namespace";
        }
        if (matches.empty())
            return "no shared variable matches path " + quoted + " (variables: " + listVariables(index) + ")";
        var = matches[0];
        consumed = var->name.size();
    }

    std::string type = var->type;
    std::vector<uint64_t> dims = var->dims;
    uint64_t offset = var->offset, size = var->size;
    std::size_t pos = consumed;
    while (pos < path.size()) {
        const std::string so_far = "'" + std::string(path.substr(0, pos)) + "'";
        if (path[pos] == '[') {
            const std::size_t close = path.find(']', pos);
            if (close == std::string_view::npos) return "path " + quoted + ": '[' without ']'";
            const std::string_view digits = path.substr(pos + 1, close - pos - 1);
            if (digits.empty() || digits.size() > 12 ||
                !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
                return "path " + quoted + ": index '" + std::string(digits) + "' is not a decimal number";
            const uint64_t i = std::stoull(std::string(digits));
            if (dims.empty()) return "path " + quoted + ": " + so_far + " is not an array";
            if (i >= dims[0])
                return "path " + quoted + ": index " + std::to_string(i) + " out of range, " + so_far + " has " +
                       std::to_string(dims[0]) + " elements (0.." + std::to_string(dims[0] - 1) + ")";
            size /= dims[0];
            offset += i * size;
            dims.erase(dims.begin());
            pos = close + 1;
        } else if (path[pos] == '.') {
            std::size_t end = pos + 1;
            while (end < path.size() && path[end] != '.' && path[end] != '[') ++end;
            const std::string member(path.substr(pos + 1, end - pos - 1));
            if (member.empty()) return "path " + quoted + ": empty member name after " + so_far;
            if (!dims.empty())
                return "path " + quoted + ": " + so_far + " is an array of " + std::to_string(dims[0]) +
                       ": index it before ." + member;
            auto t = index.types.find(type);
            if (t == index.types.end())
                return "path " + quoted + ": " + so_far + " is a " + type + ", it has no member " + member;
            const Field *field = nullptr;
            for (const Field &f : t->second.fields)
                if (f.name == member) field = &f;
            if (!field) {
                std::string members;
                for (const Field &f : t->second.fields) members += (members.empty() ? "" : ", ") + f.name;
                return "path " + quoted + ": " + so_far + " has no member " + member + " (members: " + members + ")";
            }
            offset += field->offset;
            size = field->size;
            dims = field->dims;
            type = field->type;
            pos = end;
        } else {
            return "path " + quoted + ": unexpected '" + std::string(1, path[pos]) + "' after " + so_far;
        }
    }
    if (offset + size > index.data_size) return "path " + quoted + " lies outside the data area";  // a corrupt layout
    out = Target{offset, size, var->lock};
    return "";
}

}  // namespace

struct Handle::Impl {
    std::shared_ptr<const LayoutIndex> layout;
    std::unordered_map<std::string, Target, StringHash, std::equal_to<>> paths;
};

// What the free functions need of a Handle.
struct Access {
    static void clear(Handle &h) noexcept { h.error_[0] = '\0'; }

    static int fail(Handle &h, const char *format, ...) __attribute__((format(printf, 2, 3))) {
        va_list args;
        va_start(args, format);
        std::vsnprintf(h.error_, sizeof h.error_, format, args);
        va_end(args);
        return -1;
    }

    static int connect(Handle &h) noexcept {
        clear(h);
        const indurop_segment_header *segment = irp::shared::segmentHeader();
        if (!segment || !indurop_shared_data) {
            h.impl_.reset();
            const std::string &why = irp::shared::attachError();
            if (!why.empty()) return fail(h, "no shared-variable segment: %s", why.c_str());
            return fail(h, "no shared-variable segment: this process was started without one (INDUROP_SHM is not set; "
                           "the set needs a <layout>)");
        }
        try {
            auto impl = std::make_unique<Handle::Impl>();
            impl->layout = layoutFor(segment);
            if (!impl->layout->error.empty()) return fail(h, "%s", impl->layout->error.c_str());
            h.impl_ = std::move(impl);
        } catch (const std::exception &e) {
            return fail(h, "cannot connect: %s", e.what());
        }
        return 0;
    }

    // The target of path, resolved and cached on first use; null after fail().
    static const Target *target(Handle &h, const char *path) noexcept {
        clear(h);
        if (!h.impl_ || !h.impl_->layout->sameSegment(irp::shared::segmentHeader())) {
            if (connect(h) != 0) return nullptr;
        }
        if (!path) return fail(h, "path is null"), nullptr;
        const std::string_view p(path, strnlen(path, kMaxPathLength + 1));
        if (p.size() > kMaxPathLength) return fail(h, "path longer than %zu characters", kMaxPathLength), nullptr;
        auto &paths = h.impl_->paths;
        if (auto it = paths.find(p); it != paths.end()) return &it->second;
        try {
            Target t;
            const std::string why = resolve(*h.impl_->layout, p, t);
            if (!why.empty()) return fail(h, "%s", why.c_str()), nullptr;
            if (paths.size() >= kMaxCachedPaths) paths.clear();
            return &paths.emplace(std::string(p), t).first->second;
        } catch (const std::exception &e) {
            return fail(h, "path '%.*s': %s", static_cast<int>(p.size()), p.data(), e.what()), nullptr;
        }
    }

    static int checkSize(Handle &h, const char *path, const Target &t, std::size_t size) noexcept {
        if (size == t.size) return 0;
        return fail(h, "size %zu given for '%s', which is %llu bytes", size, path,
                    static_cast<unsigned long long>(t.size));
    }

    static const char *error(const Handle &h) noexcept { return h.error_; }
};

Handle::Handle() noexcept { error_[0] = '\0'; }
Handle::~Handle() = default;
Handle::Handle(Handle &&other) noexcept : impl_(std::move(other.impl_)) {
    std::memcpy(error_, other.error_, sizeof error_);
    other.error_[0] = '\0';
}
Handle &Handle::operator=(Handle &&other) noexcept {
    if (this != &other) {
        impl_ = std::move(other.impl_);
        std::memcpy(error_, other.error_, sizeof error_);
        other.error_[0] = '\0';
    }
    return *this;
}

int connect(Handle &handle) { return Access::connect(handle); }

const char *lastError(const Handle &handle) noexcept { return Access::error(handle); }

}  // namespace channel

// Scalars of up to 8 bytes go through an aligned buffer, so that the copy is one atomic access
// whatever the caller's alignment: a top-level scalar is written by generated code with a
// plain atomic store, outside the seqlock.
int read(channel::Handle &handle, const char *path, std::size_t size, void *out) {
    using channel::Access;
    const channel::Target *t = Access::target(handle, path);
    if (!t) return -1;
    if (Access::checkSize(handle, path, *t, size) != 0) return -1;
    if (!out) return Access::fail(handle, "read '%s': the destination is null", path);
    const char *source = indurop_shared_data + t->offset;
    if (size <= 8) {
        alignas(8) unsigned char buffer[8];
        irp::shared::detail::readConsistent(t->lock, [&] { irp::shared::detail::atomicCopy(buffer, source, size); });
        std::memcpy(out, buffer, size);
    } else {
        irp::shared::detail::readConsistent(t->lock, [&] { irp::shared::detail::atomicCopy(out, source, size); });
    }
    return static_cast<int>(size);
}

int write(channel::Handle &handle, const char *path, std::size_t size, const void *in) {
    using channel::Access;
    const channel::Target *t = Access::target(handle, path);
    if (!t) return -1;
    if (Access::checkSize(handle, path, *t, size) != 0) return -1;
    if (!in) return Access::fail(handle, "write '%s': the source is null", path);
    char *destination = indurop_shared_data + t->offset;
    if (size <= 8) {
        alignas(8) unsigned char buffer[8];
        std::memcpy(buffer, in, size);
        irp::shared::detail::writeExclusive(t->lock,
                                            [&] { irp::shared::detail::atomicCopy(destination, buffer, size); });
    } else {
        irp::shared::detail::writeExclusive(t->lock, [&] { irp::shared::detail::atomicCopy(destination, in, size); });
    }
    return static_cast<int>(size);
}
