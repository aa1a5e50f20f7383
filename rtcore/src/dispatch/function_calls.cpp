// function_calls.cpp -- the function table for process modules, and serving their calls in the
// owners' slots.  publish() and stop() run on irpd's non-RT thread; serve() on an executor's RT
// thread.
#include "dispatch/function_calls.hpp"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>
#include <exception>

namespace irp::dispatch {
namespace {

template <class T>
std::atomic_ref<T> atomic(T &word) noexcept {
    return std::atomic_ref<T>(word);
}

// Copies text into a fixed char field, 0-terminated, cut if it does not fit.
template <std::size_t N>
void copyText(char (&field)[N], const std::string &text) {
    std::snprintf(field, N, "%s", text.c_str());
}

int32_t refusalOf(const runtime::FunctionExport &e, const config::ModuleSpec *owner) {
    if (!e.shape.thunk) return INDUROP_CALL_NOT_TRANSFERABLE;
    if (e.shape.args_size > INDUROP_CALL_BYTES || e.shape.result_size > INDUROP_CALL_BYTES)
        return INDUROP_CALL_TOO_LARGE;
    if (!owner || owner->type != config::ModuleType::Thread || owner->operation != config::OperationType::Periodic)
        return INDUROP_CALL_NOT_SERVED;
    return INDUROP_CALL_OK;
}

// The module of `set` that exported x, or null.
const config::ModuleSpec *ownerOf(const runtime::FunctionExport &x, const config::SetSpec &set) {
    const config::ModuleSpec *owner = nullptr;
    for (const config::ModuleSpec &m : set.modules)
        if (!x.owner.empty() && m.name == x.owner) owner = &m;
    return owner;
}

// The answer to one request taken by the owner (the area is SERVING: the process leaves it alone).
void answer(indurop_call_area &a, const CallServer::Function &f, uint64_t cycle, bool disabled) noexcept {
    int32_t status = INDUROP_CALL_OK;
    if (disabled)
        status = INDUROP_CALL_OWNER_DISABLED;
    else if (f.refusal != INDUROP_CALL_OK || !f.thunk)
        status = f.refusal ? f.refusal : INDUROP_CALL_NOT_TRANSFERABLE;
    else if (atomic(a.signature_hash).load(std::memory_order_relaxed) != f.signature_hash)
        status = INDUROP_CALL_SIGNATURE_MISMATCH;
    else if (atomic(a.args_size).load(std::memory_order_relaxed) != f.args_size ||
             atomic(a.result_size).load(std::memory_order_relaxed) != f.result_size)
        status = INDUROP_CALL_BAD_REQUEST;
    else {
        try {
            f.thunk(f.fn, a.args, a.result);
        } catch (const std::exception &e) {
            status = INDUROP_CALL_THREW;
            std::snprintf(reinterpret_cast<char *>(a.result), sizeof a.result, "%s", e.what());
        } catch (...) {
            status = INDUROP_CALL_THREW;
            std::snprintf(reinterpret_cast<char *>(a.result), sizeof a.result, "a non-standard exception");
        }
    }
    atomic(a.served_cycle).store(cycle, std::memory_order_relaxed);
    atomic(a.status).store(status, std::memory_order_relaxed);
}

}  // namespace

std::unique_ptr<CallServer> CallServer::publish(hosts::ControlSegment &control, const config::SetSpec &set,
                                                const std::vector<runtime::FunctionExport> &exports,
                                                std::vector<std::string> &notes) {
    auto server = std::make_unique<CallServer>();
    server->header_ = control.header();
    for (uint32_t s = 0; s < control.slotCount(); ++s) server->slots_.push_back(&control.slot(s));
    server->forModulesOf(set);
    const uint32_t count = std::min<uint32_t>(control.functionCount(), static_cast<uint32_t>(exports.size()));
    for (uint32_t i = 0; i < count; ++i) {
        const runtime::FunctionExport &x = exports[i];
        const config::ModuleSpec *owner = ownerOf(x, set);
        indurop_function_entry &e = control.function(i);
        e = indurop_function_entry{};
        if (x.name.size() < sizeof e.name)
            copyText(e.name, x.name);  // a longer name stays unlisted: "" never matches
        else
            notes.push_back("shared function '" + x.name + "': its name is longer than " +
                            std::to_string(sizeof e.name - 1) + " characters, process modules cannot call it");
        copyText(e.signature, x.signature);
        copyText(e.owner, x.owner);
        e.signature_hash = runtime::signatureHash(x.signature.c_str());
        e.owner_index = owner ? static_cast<uint32_t>(owner->index) : UINT32_MAX;
        e.args_size = x.shape.args_size;
        e.result_size = x.shape.result_size;

        Function f;
        f.signature_hash = e.signature_hash;
        f.args_size = e.args_size;
        f.result_size = e.result_size;
        server->bind(f, x, owner);
        e.refusal = static_cast<uint32_t>(f.refusal);
        e.owner_period_ns = owner && e.refusal != INDUROP_CALL_NOT_SERVED ? owner->period_ns : 0;
        server->functions_.push_back(f);
        server->names_.push_back(x.name);
    }
    atomic(server->header_->calls).store(INDUROP_CALLS_SERVING, std::memory_order_release);
    return server;
}

Result<std::unique_ptr<CallServer>> CallServer::rebind(const config::SetSpec &set,
                                                       const std::vector<runtime::FunctionExport> &exports) const {
    auto server = std::make_unique<CallServer>();
    server->header_ = header_;
    server->slots_ = slots_;
    server->names_ = names_;
    server->forModulesOf(set);
    for (std::size_t i = 0; i < functions_.size(); ++i) {
        const Function &was = functions_[i];
        const runtime::FunctionExport *x = nullptr;
        for (const runtime::FunctionExport &e : exports)
            if (e.name == names_[i]) x = &e;
        const std::string why = "process modules may call shared function '" + names_[i] +
                                "' (the function table "
                                "irpd published at start): ";
        if (!x) return Error{why + "no module of the set exports it any more; a restart publishes the table anew"};
        if (runtime::signatureHash(x->signature.c_str()) != was.signature_hash || x->shape.args_size != was.args_size ||
            x->shape.result_size != was.result_size)
            return Error{why + "its signature changes; a restart publishes the table anew"};
        Function f = was;
        server->bind(f, *x, ownerOf(*x, set));
        server->functions_.push_back(f);
    }
    return server;
}

void CallServer::forModulesOf(const config::SetSpec &set) {
    cursor_.assign(set.modules.size(), 0);
    serves_.assign(set.modules.size(), 0);
    owners_.clear();
    for (const config::ModuleSpec &m : set.modules) owners_.push_back(m.name);
}

void CallServer::bind(Function &f, const runtime::FunctionExport &x, const config::ModuleSpec *owner) {
    f.fn = x.fn;
    f.refusal = refusalOf(x, owner);
    f.thunk = f.refusal == INDUROP_CALL_OK ? x.shape.thunk : nullptr;
    f.owner = owner ? owner->index : -1;
    if (f.refusal == INDUROP_CALL_OK && f.owner >= 0) serves_[static_cast<std::size_t>(f.owner)] = 1;
}

int CallServer::ownerId(const std::string &name) const {
    for (std::size_t i = 0; i < owners_.size(); ++i)
        if (owners_[i] == name) return static_cast<int>(i);
    return -1;
}

bool CallServer::serves(int module) const {
    return module >= 0 && static_cast<std::size_t>(module) < serves_.size() &&
           serves_[static_cast<std::size_t>(module)];
}

unsigned CallServer::serve(int module, uint64_t cycle, bool disabled) noexcept {
    const auto n = static_cast<uint32_t>(slots_.size());
    if (n == 0 || !serves(module)) return 0;
    uint32_t &cursor = cursor_[static_cast<std::size_t>(module)];
    uint32_t next = cursor;
    unsigned served = 0;
    for (uint32_t k = 0; k < n && served < kCallsServedPerPeriod; ++k) {
        const uint32_t i = (cursor + k) % n;
        indurop_call_area &a = slots_[i]->call;
        uint32_t word = atomic(a.word).load(std::memory_order_acquire);
        if (INDUROP_CALL_PHASE(word) != INDUROP_CALL_PENDING) continue;
        // Another owner's request, or one of a module on another executor: not ours to take.  (A
        // function index read while the process replaces its request is caught by the CAS below:
        // the word's tag changed.)
        const uint32_t fn = atomic(a.function).load(std::memory_order_relaxed);
        if (fn >= functions_.size() || functions_[fn].owner != module) continue;
        if (!atomic(a.word).compare_exchange_strong(word, (word & ~3u) | INDUROP_CALL_SERVING,
                                                    std::memory_order_acq_rel))
            continue;  // withdrawn by its timeout just now
        answer(a, functions_[fn], cycle, disabled);
        atomic(a.word).store((word & ~3u) | INDUROP_CALL_ANSWERED, std::memory_order_release);
        futex::wakeAll(&a.word);
        ++served;
        next = i + 1 == n ? 0 : i + 1;
    }
    cursor = next;
    return served;
}

void CallServer::stop() noexcept {
    if (!header_) return;
    atomic(header_->calls).store(INDUROP_CALLS_STOPPED, std::memory_order_release);
    for (indurop_process_slot *s : slots_) futex::wakeAll(&s->call.word);
}

}  // namespace irp::dispatch
