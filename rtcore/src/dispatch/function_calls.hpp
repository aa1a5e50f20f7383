// function_calls.hpp -- irpd's side of calls from process modules to the shared functions of
// thread modules: the function table published in the control segment, and the serving of the
// requests right after the owner's run(), in its slot (protocol: <indurop/control.h>; the process
// side: rtcore/sdk/calls.cpp; the contract: docs/shared-variables.md, "Shared functions").
#pragma once

#include <indurop/result.hpp>
#include "config/module_xml.hpp"
#include "hosts/control_segment.hpp"
#include "sdk/runtime.hpp"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace irp::dispatch {

class CallServer {
public:
    // Writes the table of `exports` (runtime::functionExports(): every export, sorted by name)
    // into `control`, created with room for exports.size() entries, and marks it served.  Each
    // entry says whether processes may call it: its types must cross a process boundary, its
    // packed arguments and result fit INDUROP_CALL_BYTES, and its owner be a periodic thread
    // module of `set` (only those have a period to serve calls in).  Every slot's call area is
    // served, whatever the process's kind.  `notes`: lines for irpd's log (exports a process cannot
    // even name).  Call after every module's start() and before any process starts.
    static std::unique_ptr<CallServer> publish(hosts::ControlSegment &control, const config::SetSpec &set,
                                               const std::vector<runtime::FunctionExport> &exports,
                                               std::vector<std::string> &notes);

    // The server of a hot reload's new generation: the same table (processes resolved its
    // functions by index), each function bound to the newest export of its name (a replaced
    // exporter's new code) and to its owner's index in `set`.  An Error when a function of the
    // table is no longer exported, or with another signature or size: processes would call what
    // is not there (a restart republishes the table).  Functions new since the table was published
    // stay invisible to processes.
    Result<std::unique_ptr<CallServer>> rebind(const config::SetSpec &set,
                                               const std::vector<runtime::FunctionExport> &exports) const;

    // Whether module (its owner id) owns a function processes may call: its task serves.
    bool serves(int module) const;
    // A module's owner id: its index in the set the table was published for (the set irpd
    // started with; the table is not republished by hot reloads), or -1.
    int ownerId(const std::string &name) const;

    // The RT part, called by the owner's executor right after its run(): takes up to
    // irp::kCallsServedPerPeriod pending requests for module's functions (scanning the call areas
    // from where its last scan stopped, so that no process starves), calls each through its
    // thunk, writes the status and result, and wakes the caller.  A disabled owner answers
    // OWNER_DISABLED instead.  cycle goes into the answer (served_cycle).  No allocation, no lock,
    // no blocking: atomics, the function itself, one FUTEX_WAKE per answer.  Returns how many.
    unsigned serve(int module, uint64_t cycle, bool disabled) noexcept;

    // After the dispatcher stopped: marks the table STOPPED and wakes every waiting caller, whose
    // call then returns INDUROP_CALL_STOPPED at once instead of waiting out its timeout.
    void stop() noexcept;

    // What serve() calls for each table entry.
    struct Function {
        detail::AnyFunction fn = nullptr;
        detail::Thunk thunk = nullptr;  // null: refused (see refusal)
        uint64_t signature_hash = 0;
        uint32_t args_size = 0;
        uint32_t result_size = 0;
        int32_t refusal = 0;  // enum indurop_call_status; 0 = callable
        int owner = -1;       // module index, -1 = none
    };

private:
    // Per-module state for `set`: an owner id is a module's index in it.
    void forModulesOf(const config::SetSpec &set);
    // f calls export x of `owner` (null: none in the set); marks the owner as serving when callable.
    void bind(Function &f, const runtime::FunctionExport &x, const config::ModuleSpec *owner);

    indurop_control_header *header_ = nullptr;
    std::vector<indurop_process_slot *> slots_;  // every process's call area
    std::vector<Function> functions_;            // in table order
    std::vector<std::string> names_;             // in table order
    std::vector<uint32_t> cursor_;               // per module: the slot its next scan starts at
    std::vector<char> serves_;                   // per module
    std::vector<std::string> owners_;            // per module: its name
};

}  // namespace irp::dispatch
