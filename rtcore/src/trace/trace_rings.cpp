// trace_rings.cpp -- the trace segment, the double-buffered channel configuration and the RT sampler.
#include "trace/trace_rings.hpp"

#include "variables/variable_segment.hpp"

#include <indurop/segment.h>
#include <indurop/shared.h>

#include <signal.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>
#include <new>
#include <thread>
#include <unordered_map>

namespace irp::trace {
namespace {

constexpr uint64_t roundUp(uint64_t v) { return (v + 63) & ~uint64_t{63}; }

// Atomic access to the plain fields of the C layout (each naturally aligned).
template <class T>
T loadAcquire(const T &field) noexcept {
    return __atomic_load_n(&field, __ATOMIC_ACQUIRE);
}
template <class T>
T loadRelaxed(const T &field) noexcept {
    return __atomic_load_n(&field, __ATOMIC_RELAXED);
}
template <class T>
void storeRelease(T &field, T v) noexcept {
    __atomic_store_n(&field, v, __ATOMIC_RELEASE);
}
template <class T>
void storeRelaxed(T &field, T v) noexcept {
    __atomic_store_n(&field, v, __ATOMIC_RELAXED);
}

indurop_trace_config *configs(indurop_trace_header *h) {
    return reinterpret_cast<indurop_trace_config *>(reinterpret_cast<char *>(h) + h->configs_offset);
}

// The scalar kinds of a layout ("scalars": {"uint32_t": {"size": 4, "kind": "unsigned"}}) as trace types.
indurop_trace_type traceType(const std::string &kind, uint64_t size) {
    if (kind == "float")
        return size == 4 ? INDUROP_TRACE_FLOAT32 : size == 8 ? INDUROP_TRACE_FLOAT64 : INDUROP_TRACE_NONE;
    if (kind == "bool") return size == 1 ? INDUROP_TRACE_BOOL : INDUROP_TRACE_NONE;
    const bool sign = kind == "signed";
    if (!sign && kind != "unsigned") return INDUROP_TRACE_NONE;
    switch (size) {
    case 1: return sign ? INDUROP_TRACE_INT8 : INDUROP_TRACE_UINT8;
    case 2: return sign ? INDUROP_TRACE_INT16 : INDUROP_TRACE_UINT16;
    case 4: return sign ? INDUROP_TRACE_INT32 : INDUROP_TRACE_UINT32;
    case 8: return sign ? INDUROP_TRACE_INT64 : INDUROP_TRACE_UINT64;
    default: return INDUROP_TRACE_NONE;
    }
}

}  // namespace

// One channel as the sampler reads it: where the value is, its lock's sequence, what it is.
struct RtChannel {
    const unsigned char *value = nullptr;
    const uint32_t *seq = nullptr;
    uint32_t type = INDUROP_TRACE_NONE;
    double last = std::numeric_limits<double>::quiet_NaN();  // taken when a writer stays inside
};

struct TraceRings::Resolved {
    std::string path;
    std::string ctype;  // the layout's spelling ("uint32_t")
    indurop_trace_channel shm{};
    RtChannel rt;
};

// Written by the RT thread only (apply() reads `staged`, which the control thread filled before
// publishing it through pending_config).
struct TraceRings::Sampler {
    RtChannel channels[kMaxChannels];
    uint32_t count = 0;
    uint64_t head = 0;
    uint64_t torn = 0;
    RtChannel staged[2][kMaxChannels];  // per config buffer: its channels, resolved in this process
};

struct TraceRings::Control {
    struct Leaf {
        uint64_t offset;
        uint32_t lock;
        uint32_t size;
        std::string type;
    };
    mutable std::mutex mutex;
    uint32_t last_submitted = 0;   // the buffer last written and asked for (0: the initial, empty one)
    uint64_t next_generation = 3;  // 1 and 2 are the initial buffers'
    uint64_t requested_generation = 1;
    std::vector<Resolved> requested;
    // The layout of the variables segment last resolved against, by hash.
    std::string layout_hash;
    std::unordered_map<std::string, Leaf> leaves;
    std::unordered_map<std::string, std::pair<std::string, uint64_t>> scalars;  // type -> kind, size
    std::vector<std::string> leaf_order;
    std::map<std::string, std::vector<std::string>> owners;  // each reader's request (configureFor)
};

std::string TraceRings::shmName(const std::string &instance) { return "/indurop." + instance + ".trace"; }

TraceRings::TraceRings(TraceRings &&) noexcept = default;
TraceRings &TraceRings::operator=(TraceRings &&) noexcept = default;
TraceRings::~TraceRings() = default;

Result<TraceRings> TraceRings::create(const std::string &instance, uint64_t capacity) {
    if (capacity < 2 || capacity > kMaxCapacity || !std::has_single_bit(capacity))
        return Error{"trace rings: capacity " + std::to_string(capacity) + " is not a power of two from 2 to " +
                     std::to_string(kMaxCapacity)};
    const uint64_t configs_offset = roundUp(sizeof(indurop_trace_header));
    const uint64_t seq_offset = roundUp(configs_offset + 2 * sizeof(indurop_trace_config));
    const uint64_t time_offset = roundUp(seq_offset + capacity * sizeof(uint64_t));
    const uint64_t values_offset = roundUp(time_offset + capacity * sizeof(int64_t));
    const uint64_t total = values_offset + uint64_t{kMaxChannels} * capacity * sizeof(double);

    const std::string name = shmName(instance);
    auto shm =
        osal::SharedMemory::createForInstance(name, total, instance, [](const osal::SharedMemory &old) -> int64_t {
            const auto *h = static_cast<const indurop_trace_header *>(old.data());
            return old.size() >= sizeof *h && h->magic == INDUROP_TRACE_MAGIC ? h->owner_pid : 0;
        });
    if (!shm) return shm.error();
    // Touch every page now (and lock them where the limit allows): the RT thread must not fault.
    std::memset(shm->data(), 0, total);
    mlock(shm->data(), total);

    auto *h = new (shm->data()) indurop_trace_header{};
    h->version = INDUROP_TRACE_VERSION;
    h->header_size = sizeof(indurop_trace_header);
    h->total_size = total;
    h->capacity = capacity;
    h->channel_max = kMaxChannels;
    h->channel_size = sizeof(indurop_trace_channel);
    h->config_size = sizeof(indurop_trace_config);
    h->configs_offset = configs_offset;
    h->seq_offset = seq_offset;
    h->time_offset = time_offset;
    h->values_offset = values_offset;
    h->owner_pid = getpid();
    // Buffer 0: no channels, in force from the first row; buffer 1: no channels, never in force.
    indurop_trace_config *c = configs(h);
    new (&c[0]) indurop_trace_config{};
    new (&c[1]) indurop_trace_config{};
    c[0].generation = 1;
    c[0].first_seq = 1;
    c[1].generation = 2;
    c[1].first_seq = INDUROP_TRACE_NO_SEQ;
    h->config_generation = 1;
    h->config_seq = 1;
    h->active_config = 0;
    storeRelease(h->magic, uint64_t{INDUROP_TRACE_MAGIC});  // last: a reader seeing the magic sees the rest

    TraceRings rings;
    rings.shm_ = std::move(*shm);
    rings.header_ = h;
    rings.sampler_ = std::make_unique<Sampler>();
    rings.control_ = std::make_unique<Control>();
    return rings;
}

void TraceRings::setBasicPeriod(int64_t ns) noexcept {
    if (header_) storeRelaxed(header_->basic_period_ns, ns);
}

uint64_t TraceRings::requestedGeneration() const {
    std::lock_guard lock(control_->mutex);
    return control_->requested_generation;
}

Result<json> TraceRings::configure(const std::vector<std::string> &paths, const variables::VariableSegment &vars) {
    if (!header_) return Error{"trace rings: not created"};
    if (paths.size() > kMaxChannels)
        return Error{std::to_string(paths.size()) + " channels asked for; at most " + std::to_string(kMaxChannels) +
                     " can be traced (the first one over is '" + paths[kMaxChannels] + "')"};
    const auto *vh = vars.header();
    const char *base = reinterpret_cast<const char *>(vh);
    std::unique_lock lock(control_->mutex);
    Control &c = *control_;

    // The layout, parsed once per publication (irpd copies it into the segment; an online change
    // publishes another).
    std::string hash, text;
    irp::segment::copyLayout(vh, hash, text);
    if (c.layout_hash != hash) {
        c.leaves.clear();
        c.scalars.clear();
        c.leaf_order.clear();
        try {
            auto layout = nlohmann::json::parse(text);
            for (const auto &[type, s] : layout.at("scalars").items())
                c.scalars[type] = {s.at("kind").get<std::string>(), s.at("size").get<uint64_t>()};
            for (const auto &leaf : layout.at("leaves")) {
                auto path = leaf.at("path").get<std::string>();
                c.leaves[path] = {leaf.at("offset").get<uint64_t>(), leaf.at("lock").get<uint32_t>(),
                                  leaf.at("size").get<uint32_t>(), leaf.at("type").get<std::string>()};
                c.leaf_order.push_back(std::move(path));
            }
        } catch (const nlohmann::json::exception &e) {
            c.leaves.clear();
            return Error{"trace: the layout in " + vars.name() + " cannot be read: " + e.what()};
        }
        c.layout_hash = hash;
    }

    std::vector<Resolved> channels;
    channels.reserve(paths.size());
    for (const std::string &path : paths) {
        for (const Resolved &earlier : channels)
            if (earlier.path == path) return Error{"channel '" + path + "' is listed twice"};
        auto found = c.leaves.find(path);
        if (found == c.leaves.end()) {
            for (const std::string &leaf : c.leaf_order)
                if (leaf.size() > path.size() && leaf.compare(0, path.size(), path) == 0 &&
                    (leaf[path.size()] == '.' || leaf[path.size()] == '['))
                    return Error{"'" + path + "' is not a scalar (it holds '" + leaf +
                                 "', ...): trace its scalar members or elements one by one"};
            return Error{"no variable '" + path + "' in the shared-variable layout " + hash.substr(0, 12) + "…"};
        }
        const Control::Leaf &leaf = found->second;
        auto scalar = c.scalars.find(leaf.type);
        const indurop_trace_type type =
            scalar == c.scalars.end() ? INDUROP_TRACE_NONE : traceType(scalar->second.first, scalar->second.second);
        if (type == INDUROP_TRACE_NONE || scalar->second.second != leaf.size)
            return Error{"'" + path + "' is a " + leaf.type + ", which cannot be traced"};
        if (leaf.offset + leaf.size > vh->data_size || leaf.offset % leaf.size != 0 || leaf.lock >= vh->lock_count)
            return Error{"'" + path + "' lies outside the data area or is misaligned in " + vars.name()};
        if (path.size() >= INDUROP_TRACE_PATH_CHARS)
            return Error{"'" + path + "' is longer than " + std::to_string(INDUROP_TRACE_PATH_CHARS - 1) +
                         " characters, the longest path the trace can name"};
        Resolved r;
        r.path = path;
        r.ctype = leaf.type;
        std::memcpy(r.shm.path, path.data(), path.size());
        r.shm.offset = leaf.offset;
        r.shm.type = type;
        r.shm.lock = leaf.lock;
        r.shm.size = leaf.size;
        r.rt.value = reinterpret_cast<const unsigned char *>(base + vh->data_offset + leaf.offset);
        r.rt.seq = reinterpret_cast<const uint32_t *>(base + vh->locks_offset + uint64_t{leaf.lock} * vh->lock_size +
                                                      offsetof(indurop_var_lock, seq));
        r.rt.type = type;
        channels.push_back(std::move(r));
    }
    lock.unlock();
    return submit(std::move(channels));
}

Result<json> TraceRings::configureFor(const std::string &owner, const std::vector<std::string> &paths,
                                      const variables::VariableSegment *vars) {
    if (!header_) return Error{"trace rings: not created"};
    for (std::size_t i = 0; i < paths.size(); ++i)
        for (std::size_t j = 0; j < i; ++j)
            if (paths[i] == paths[j]) return Error{"channel '" + paths[i] + "' is listed twice"};
    std::map<std::string, std::vector<std::string>> owners;
    std::vector<std::string> in_force;
    {
        std::lock_guard lock(control_->mutex);
        owners = control_->owners;
        for (const Resolved &r : control_->requested) in_force.push_back(r.path);
    }
    if (paths.empty())
        owners.erase(owner);
    else
        owners[owner] = paths;
    auto wanted = [&](const std::string &path) {
        for (const auto &[who, list] : owners)
            if (std::find(list.begin(), list.end(), path) != list.end()) return true;
        return false;
    };
    std::vector<std::string> traced;
    for (const std::string &path : in_force)
        if (wanted(path)) traced.push_back(path);
    for (const auto &[who, list] : owners)
        for (const std::string &path : list)
            if (std::find(traced.begin(), traced.end(), path) == traced.end()) traced.push_back(path);
    if (traced.size() > kMaxChannels) {
        std::string held;
        for (const auto &[who, list] : owners)
            held += (held.empty() ? "" : ", ") + who + ": " + std::to_string(list.size());
        return Error{"'" + owner + "' asks for " + std::to_string(paths.size()) + " channels; with every owner's (" +
                     held + ") " + std::to_string(traced.size()) + " would be traced, at most " +
                     std::to_string(kMaxChannels) + " can be"};
    }
    Result<json> answer = Error{""};
    if (vars)
        answer = configure(traced, *vars);
    else if (traced.empty())
        answer = clear();
    else
        return Error{"the running set has no shared variables (no layout.json): '" + traced.front() +
                     "' cannot be traced"};
    if (!answer) return answer;
    {
        std::lock_guard lock(control_->mutex);
        control_->owners = std::move(owners);
    }
    return describe();
}

Result<json> TraceRings::clear() {
    if (!header_) return Error{"trace rings: not created"};
    return submit({});
}

// Writes the buffer that is not in force and asks the sampler for it.  A request the sampler has
// not taken yet is withdrawn first (a CAS on pending_config), and its buffer rewritten: so the
// sampler never reads a buffer being written, and this never waits for the sampler.
Result<json> TraceRings::submit(std::vector<Resolved> channels) {
    {
        std::lock_guard lock(control_->mutex);
        Control &c = *control_;
        uint32_t target;
        uint32_t expected = c.last_submitted + 1;
        if (__atomic_compare_exchange_n(&header_->pending_config, &expected, 0u, false, __ATOMIC_ACQ_REL,
                                        __ATOMIC_ACQUIRE))
            target = c.last_submitted;  // withdrawn before the sampler took it: rewrite it
        else
            target = 1 - c.last_submitted;  // taken (or the initial buffer): the other one is free

        indurop_trace_config &cfg = configs(header_)[target];
        const uint64_t generation = c.next_generation++;
        storeRelaxed(cfg.generation, uint64_t{0});  // readers: being rewritten
        std::atomic_thread_fence(std::memory_order_release);
        storeRelaxed(cfg.first_seq, INDUROP_TRACE_NO_SEQ);
        cfg.channel_count = static_cast<uint32_t>(channels.size());
        for (uint32_t i = 0; i < kMaxChannels; ++i) {
            cfg.channels[i] = i < channels.size() ? channels[i].shm : indurop_trace_channel{};
            sampler_->staged[target][i] = i < channels.size() ? channels[i].rt : RtChannel{};
        }
        storeRelease(cfg.generation, generation);
        storeRelease(header_->pending_config, target + 1);
        c.last_submitted = target;
        c.requested_generation = generation;
        c.requested = std::move(channels);
    }
    return describe();
}

json TraceRings::describe() const {
    if (!header_) return json::object();
    std::lock_guard lock(control_->mutex);
    const Control &c = *control_;
    const uint64_t in_force = loadAcquire(header_->config_generation);
    const bool applied = in_force >= c.requested_generation;
    json channels = json::array();
    for (std::size_t i = 0; i < c.requested.size(); ++i)
        channels.push_back({{"index", i}, {"path", c.requested[i].path}, {"type", c.requested[i].ctype}});
    const uint64_t first = applied ? loadAcquire(configs(header_)[c.last_submitted].first_seq) : INDUROP_TRACE_NO_SEQ;
    return json{{"shm", shm_.name()},
                {"capacity", header_->capacity},
                {"basic_period_ns", loadRelaxed(header_->basic_period_ns)},
                {"generation", c.requested_generation},
                {"applied", applied},
                {"from_seq", applied && in_force == c.requested_generation && first != INDUROP_TRACE_NO_SEQ
                                 ? json(first)
                                 : json(nullptr)},
                {"head", loadAcquire(header_->head)},
                {"torn_skips", loadRelaxed(header_->torn_skips)},
                {"owners", c.owners},
                {"channels", std::move(channels)}};
}

bool TraceRings::waitApplied(uint64_t generation, int64_t timeout_ns) const {
    const auto until = std::chrono::steady_clock::now() + std::chrono::nanoseconds(timeout_ns);
    while (loadAcquire(header_->config_generation) < generation) {
        if (std::chrono::steady_clock::now() >= until) return false;
        std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    return true;
}

// ---- the RT side ------------------------------------------------------------------------------

void TraceRings::apply(uint32_t index) noexcept {
    Sampler &s = *sampler_;
    indurop_trace_config &cfg = configs(header_)[index];
    s.count = cfg.channel_count;
    for (uint32_t i = 0; i < s.count; ++i) s.channels[i] = s.staged[index][i];
    const uint64_t first = s.head + 1;
    storeRelease(cfg.first_seq, first);
    storeRelaxed(header_->config_seq, first);
    storeRelaxed(header_->active_config, index);
    storeRelease(header_->config_generation, loadRelaxed(cfg.generation));
}

namespace {

template <class T>
double loadAs(const unsigned char *p) noexcept {
    return static_cast<double>(__atomic_load_n(reinterpret_cast<const T *>(p), __ATOMIC_RELAXED));
}

double load(const RtChannel &c) noexcept {
    switch (c.type) {
    case INDUROP_TRACE_FLOAT32: {
        uint32_t bits = __atomic_load_n(reinterpret_cast<const uint32_t *>(c.value), __ATOMIC_RELAXED);
        return static_cast<double>(std::bit_cast<float>(bits));
    }
    case INDUROP_TRACE_FLOAT64:
        return std::bit_cast<double>(__atomic_load_n(reinterpret_cast<const uint64_t *>(c.value), __ATOMIC_RELAXED));
    case INDUROP_TRACE_INT8: return loadAs<int8_t>(c.value);
    case INDUROP_TRACE_INT16: return loadAs<int16_t>(c.value);
    case INDUROP_TRACE_INT32: return loadAs<int32_t>(c.value);
    case INDUROP_TRACE_INT64: return loadAs<int64_t>(c.value);
    case INDUROP_TRACE_UINT8: return loadAs<uint8_t>(c.value);
    case INDUROP_TRACE_UINT16: return loadAs<uint16_t>(c.value);
    case INDUROP_TRACE_UINT32: return loadAs<uint32_t>(c.value);
    case INDUROP_TRACE_UINT64: return loadAs<uint64_t>(c.value);
    case INDUROP_TRACE_BOOL: return __atomic_load_n(c.value, __ATOMIC_RELAXED) ? 1.0 : 0.0;
    default: return std::numeric_limits<double>::quiet_NaN();
    }
}

}  // namespace

/*
 * One row per basic period, on the RT thread:
 *   1. a configuration asked for by the control thread (pending_config) is put in force: its
 *      channels are copied, its first_seq and the header's config_seq become this row's seq;
 *   2. each channel is read as libindurop reads a variable: its lock's sequence before and after
 *      the load, retried while a writer is inside, at most kTornRetries times; then the channel's
 *      previous value is taken instead and torn_skips counted (never a lock, never a wait);
 *   3. the values, the due time and the seq are stored at index seq % capacity, then head = seq
 *      with release: a reader that sees head = seq sees the whole row.
 */
void TraceRings::sample(int64_t due_ns) noexcept {
    if (!header_) return;
    Sampler &s = *sampler_;
    if (loadRelaxed(header_->pending_config) != 0) {  // a plain load first: no locked instruction per period
        const uint32_t p = __atomic_exchange_n(&header_->pending_config, 0u, __ATOMIC_ACQ_REL);
        if (p) apply(p - 1);
    }
    const uint64_t capacity = header_->capacity;
    const uint64_t seq = s.head + 1;
    const uint64_t index = seq & (capacity - 1);
    char *base = reinterpret_cast<char *>(header_);
    auto *values = reinterpret_cast<double *>(base + header_->values_offset);
    const uint64_t torn_before = s.torn;

    // Stores of row `seq` overwrite row seq - capacity: a reader that copied any of them will see
    // head >= seq - 1 when it checks (see <indurop/trace.h>).
    std::atomic_thread_fence(std::memory_order_release);
    for (uint32_t i = 0; i < s.count; ++i) {
        RtChannel &c = s.channels[i];
        double v = c.last;
        bool read = false;
        for (int attempt = 0; attempt < kTornRetries; ++attempt) {
            const uint32_t before = __atomic_load_n(c.seq, __ATOMIC_ACQUIRE);
            if (before & 1) {
                __builtin_ia32_pause();
                continue;
            }
            const double x = load(c);
            std::atomic_thread_fence(std::memory_order_acquire);
            if (__atomic_load_n(c.seq, __ATOMIC_RELAXED) == before) {
                v = x;
                read = true;
                break;
            }
        }
        if (read)
            c.last = v;
        else
            ++s.torn;
        __atomic_store_n(reinterpret_cast<uint64_t *>(&values[i * capacity + index]), std::bit_cast<uint64_t>(v),
                         __ATOMIC_RELAXED);
    }
    storeRelaxed(reinterpret_cast<int64_t *>(base + header_->time_offset)[index], due_ns);
    storeRelaxed(reinterpret_cast<uint64_t *>(base + header_->seq_offset)[index], seq);
    if (s.torn != torn_before) storeRelaxed(header_->torn_skips, s.torn);
    storeRelease(header_->head, seq);
    s.head = seq;
}

}  // namespace irp::trace
