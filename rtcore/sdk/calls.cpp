// calls.cpp -- libindurop's side of calls from process modules to shared functions of thread
// modules (<indurop/functions.h>): the name resolved in irpd's function table, the request
// written into this process's call area, the answer awaited with a futex and a timeout.
// irpd's side is rtcore/src/dispatch/function_calls.cpp; the protocol is in <indurop/control.h>.
#include <indurop/control.h>
#include <indurop/functions.h>

#include "control_map.hpp"
#include "runtime.hpp"

#include <cxxabi.h>
#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <memory>
#include <mutex>
#include <string>

namespace irp {
namespace {

thread_local char g_error[512] = "";
thread_local int g_status = INDUROP_CALL_OK;

int fail(int status, const char *format, ...) __attribute__((format(printf, 2, 3)));
int fail(int status, const char *format, ...) {
    va_list args;
    va_start(args, format);
    std::vsnprintf(g_error, sizeof g_error, format, args);
    va_end(args);
    g_status = status;
    return -1;
}

int succeed() noexcept {
    g_error[0] = '\0';
    g_status = INDUROP_CALL_OK;
    return 0;
}

using sdk::atomic;
using sdk::monotonicNs;

// "double (double)" for "FddE"; the mangled text when it does not demangle (allocates: errors only).
std::string readable(const char *mangled) {
    int status = 0;
    std::unique_ptr<char, void (*)(void *)> text(abi::__cxa_demangle(mangled, nullptr, nullptr, &status), std::free);
    return status == 0 && text ? text.get() : mangled;
}

// "5 ms", "200 ms", "2 s": into a caller's buffer, so that the call path never allocates.
struct Human {
    char text[48];
};
Human humanNs(int64_t ns) noexcept {
    Human h{};
    if (ns >= 1'000'000'000 && ns % 1'000'000 == 0)
        std::snprintf(h.text, sizeof h.text, "%g s", static_cast<double>(ns) / 1e9);
    else if (ns >= 1'000'000)
        std::snprintf(h.text, sizeof h.text, "%g ms", static_cast<double>(ns) / 1e6);
    else if (ns >= 1'000)
        std::snprintf(h.text, sizeof h.text, "%g us", static_cast<double>(ns) / 1e3);
    else
        std::snprintf(h.text, sizeof h.text, "%lld ns", static_cast<long long>(ns));
    return h;
}

const sdk::ControlMap *control() {
    std::string why;
    const sdk::ControlMap *map = sdk::mapControl(why);
    if (!map) fail(INDUROP_CALL_NO_IRPD, "shared functions are called through irpd: %s", why.c_str());
    return map;
}

const indurop_function_entry *table(const sdk::ControlMap &map) noexcept {
    return reinterpret_cast<const indurop_function_entry *>(reinterpret_cast<const char *>(map.header) +
                                                            map.header->function_offset);
}

// "module 'x'", or "no module" for an export made outside a lifecycle call.
struct Owner {
    char text[96];
};
Owner ownerOf(const indurop_function_entry &e) noexcept {
    Owner o{};
    if (e.owner[0])
        std::snprintf(o.text, sizeof o.text, "module '%.*s'", static_cast<int>(sizeof e.owner), e.owner);
    else
        std::snprintf(o.text, sizeof o.text, "no module");
    return o;
}

// The request of a timed-out call that irpd had already taken, or one a predecessor in this slot
// left behind: settled before a new request goes in.  0, or -1 on timeout.
int takeArea(indurop_call_area &area, int64_t deadline, const char *name) {
    for (;;) {
        uint32_t word = atomic(area.word).load(std::memory_order_acquire);
        switch (INDUROP_CALL_PHASE(word)) {
        case INDUROP_CALL_IDLE: return 0;
        case INDUROP_CALL_ANSWERED:  // a late answer nobody waits for any more
        case INDUROP_CALL_PENDING:   // left by the process that had this slot before (restart)
            atomic(area.word).compare_exchange_strong(word, word & ~3u, std::memory_order_acq_rel);
            continue;
        default: {  // SERVING: irpd is inside the function right now
            const int64_t left = deadline - monotonicNs();
            if (left <= 0)
                return fail(INDUROP_CALL_TIMEOUT,
                            "shared function '%s': the timeout passed while irpd was still serving this process's "
                            "previous call (one call in flight per process)",
                            name);
            futex::wait(&area.word, word, left);
        }
        }
    }
}

// This process's calls take turns: one call area per process.
std::timed_mutex g_area_mutex;

}  // namespace

const char *lastCallError() noexcept { return g_error; }
int lastCallStatus() noexcept { return g_status; }

namespace runtime {
uint64_t signatureHash(const char *signature) noexcept {
    uint64_t h = 14695981039346656037ull;  // FNV-1a 64
    for (const char *c = signature; c && *c; ++c) h = (h ^ static_cast<unsigned char>(*c)) * 1099511628211ull;
    return h;
}
}  // namespace runtime

namespace detail {

int failCall(int status, const char *message) noexcept { return fail(status, "%s", message); }

int resolveFunction(const char *name, const char *signature, uint32_t args_size, uint32_t result_size,
                    uint32_t *index) noexcept {
    if (!name || !*name) return fail(INDUROP_CALL_INVALID, "shared function: the name is empty");
    try {
        const sdk::ControlMap *map = control();
        if (!map) return -1;
        const indurop_control_header &h = *map->header;
        const uint32_t state = atomic(map->header->calls).load(std::memory_order_acquire);
        if (state == INDUROP_CALLS_NONE)
            return fail(INDUROP_CALL_NO_IRPD,
                        "shared function '%s': irpd has published no function table (it serves calls "
                        "only to the process modules of a running set)",
                        name);
        const indurop_function_entry *entries = table(*map);
        const indurop_function_entry *e = nullptr;
        for (uint32_t i = 0; i < h.function_count && !e; ++i)
            if (std::strncmp(entries[i].name, name, sizeof entries[i].name) == 0) {
                e = &entries[i];
                *index = i;
            }
        if (!e) {
            std::string list;
            for (uint32_t i = 0; i < h.function_count; ++i) {
                if (i == 8) {
                    list += ", ...";
                    break;
                }
                list +=
                    (i ? ", " : "") + std::string(entries[i].name, strnlen(entries[i].name, sizeof entries[i].name));
            }
            return fail(INDUROP_CALL_UNKNOWN_FUNCTION,
                        "no module exports a shared function '%s' (the set exports %u: %s; export in initialize())",
                        name, h.function_count, list.empty() ? "none" : list.c_str());
        }
        const Owner owned = ownerOf(*e);
        const char *owner = owned.text;
        if (e->signature_hash != runtime::signatureHash(signature)) {
            const std::string theirs(e->signature, strnlen(e->signature, sizeof e->signature));
            return fail(INDUROP_CALL_SIGNATURE_MISMATCH, "shared function '%s' of %s is %s, not %s", name, owner,
                        readable(theirs.c_str()).c_str(), readable(signature).c_str());
        }
        switch (e->refusal) {
        case INDUROP_CALL_OK: break;
        case INDUROP_CALL_TOO_LARGE:
            return fail(
                INDUROP_CALL_TOO_LARGE,
                "shared function '%s' of %s takes %u bytes of arguments and returns %u bytes: a call from a process "
                "carries at most %u each way",
                name, owner, e->args_size, e->result_size, INDUROP_CALL_BYTES);
        case INDUROP_CALL_NOT_TRANSFERABLE:
            return fail(INDUROP_CALL_NOT_TRANSFERABLE,
                        "shared function '%s' of %s cannot be called from a process: it takes or returns a pointer, a "
                        "non-const reference or a type that is not trivially copyable",
                        name, owner);
        case INDUROP_CALL_NOT_SERVED:
            return fail(INDUROP_CALL_NOT_SERVED,
                        "shared function '%s' of %s cannot be called from a process: irpd serves calls in the owner's "
                        "period, and only periodic thread modules have one",
                        name, owner);
        default:
            return fail(static_cast<int>(e->refusal),
                        "shared function '%s' of %s cannot be called from a process (reason %u)", name, owner,
                        e->refusal);
        }
        if (e->args_size != args_size || e->result_size != result_size)  // same signature, other ABI
            return fail(
                INDUROP_CALL_SIGNATURE_MISMATCH,
                "shared function '%s' of %s: %u bytes of arguments and %u of result, this process packs %u and %u",
                name, owner, e->args_size, e->result_size, args_size, result_size);
        return succeed();
    } catch (const std::exception &x) {  // allocation while formatting a message
        return fail(INDUROP_CALL_INVALID, "shared function '%s': %s", name, x.what());
    }
}

int callResolved(uint32_t index, const char *signature, const void *args, uint32_t args_size, void *result,
                 uint32_t result_size, int64_t timeout_ns) noexcept {
    std::string why;
    const sdk::ControlMap *map = sdk::mapControl(why);  // mapped by resolveFunction: one load
    if (!map) return fail(INDUROP_CALL_NO_IRPD, "shared functions are called through irpd: %s", why.c_str());
    const indurop_function_entry &e = table(*map)[index];
    if (timeout_ns <= 0)
        return fail(INDUROP_CALL_INVALID, "shared function '%s': the timeout must be positive (it is %lld ns)", e.name,
                    static_cast<long long>(timeout_ns));
    if (args_size > INDUROP_CALL_BYTES || result_size > INDUROP_CALL_BYTES)
        return fail(INDUROP_CALL_TOO_LARGE, "shared function '%s': more than %u bytes", e.name, INDUROP_CALL_BYTES);
    const int64_t start = monotonicNs();
    const int64_t deadline = timeout_ns > INT64_MAX - start ? INT64_MAX : start + timeout_ns;
    indurop_control_header &h = *map->header;
    indurop_call_area &area = map->slot->call;

    std::unique_lock<std::timed_mutex> turn(g_area_mutex, std::defer_lock);
    if (!turn.try_lock_for(std::chrono::nanoseconds(timeout_ns)))
        return fail(INDUROP_CALL_TIMEOUT,
                    "shared function '%s': no answer within %s (another thread of this process was "
                    "calling, one call in flight per process)",
                    e.name, humanNs(timeout_ns).text);
    if (takeArea(area, deadline, e.name) != 0) return -1;

    // The request; PENDING (with the next tag) publishes it.
    const uint32_t idle = atomic(area.word).load(std::memory_order_relaxed);
    const uint32_t tag = INDUROP_CALL_TAG(idle) + 1;
    const uint32_t pending = (tag << 2) | INDUROP_CALL_PENDING;
    atomic(area.function).store(index, std::memory_order_relaxed);
    atomic(area.signature_hash).store(runtime::signatureHash(signature), std::memory_order_relaxed);
    atomic(area.args_size).store(args_size, std::memory_order_relaxed);
    atomic(area.result_size).store(result_size, std::memory_order_relaxed);
    atomic(area.status).store(INDUROP_CALL_OK, std::memory_order_relaxed);
    if (args_size) std::memcpy(area.args, args, args_size);
    atomic(area.word).store(pending, std::memory_order_release);  // irpd polls; no wake needed

    for (;;) {
        uint32_t word = atomic(area.word).load(std::memory_order_acquire);
        if (word == ((tag << 2) | INDUROP_CALL_ANSWERED)) {
            const int32_t status = atomic(area.status).load(std::memory_order_relaxed);
            if (status == INDUROP_CALL_OK && result_size) std::memcpy(result, area.result, result_size);
            char message[INDUROP_CALL_BYTES];
            if (status == INDUROP_CALL_THREW) {
                std::memcpy(message, area.result, sizeof message);
                message[sizeof message - 1] = '\0';
            }
            atomic(area.word).store((tag << 2) | INDUROP_CALL_IDLE, std::memory_order_release);
            const Owner owned = ownerOf(e);
            const char *owner = owned.text;
            switch (status) {
            case INDUROP_CALL_OK: return succeed();
            case INDUROP_CALL_OWNER_DISABLED:
                return fail(status,
                            "shared function '%s': %s is disabled (it threw from run()); irpd answers its calls "
                            "with this error",
                            e.name, owner);
            case INDUROP_CALL_THREW:
                return fail(status, "shared function '%s' of %s threw: %s", e.name, owner, message);
            case INDUROP_CALL_SIGNATURE_MISMATCH:
                return fail(status, "shared function '%s' of %s: irpd refused the call, its signature is %s, not %s",
                            e.name, owner, readable(e.signature).c_str(), readable(signature).c_str());
            default:
                return fail(status,
                            "shared function '%s' of %s: irpd refused the call (status %d: the request does not "
                            "match the export)",
                            e.name, owner, static_cast<int>(status));
            }
        }
        const bool stopping = atomic(h.calls).load(std::memory_order_acquire) == INDUROP_CALLS_STOPPED ||
                              atomic(map->slot->stop_requested).load(std::memory_order_acquire) != 0;
        const int64_t left = deadline - monotonicNs();
        if (stopping || left <= 0) {
            // Withdraw the request unless irpd took it already (then its answer is dropped by the next call).
            uint32_t expected = pending;
            const bool withdrawn = atomic(area.word).compare_exchange_strong(expected, (tag << 2) | INDUROP_CALL_IDLE,
                                                                             std::memory_order_acq_rel);
            if (!withdrawn && expected == ((tag << 2) | INDUROP_CALL_ANSWERED)) continue;  // answered just now: take it
            if (stopping)
                return fail(INDUROP_CALL_STOPPED, "shared function '%s': irpd is stopping and serves no more calls",
                            e.name);
            if (e.owner_period_ns > 0)
                return fail(
                    INDUROP_CALL_TIMEOUT,
                    "shared function '%s': no answer within %s (irpd serves it after each run() of %s, every %s)",
                    e.name, humanNs(timeout_ns).text, ownerOf(e).text, humanNs(e.owner_period_ns).text);
            return fail(INDUROP_CALL_TIMEOUT, "shared function '%s': no answer within %s", e.name,
                        humanNs(timeout_ns).text);
        }
        futex::wait(&area.word, word, left);
    }
}

}  // namespace detail
}  // namespace irp
