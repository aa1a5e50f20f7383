// thread_module.hpp -- the host of one thread module: dlopen, the lifecycle calls, dlclose.
//
// A module is either a descriptor module (INDUROP_MODULE, the symbol indurop_module_v1_descriptor)
// or a plain one (extern "C" initialize/start/run/stop/condition); both end up as one
// indurop_module_v1 table here, so the dispatcher calls run() through one pointer either way.
#pragma once

#include <indurop/result.hpp>
#include "config/module_xml.hpp"
#include "dispatch/fault_note.hpp"
#include "sdk/layouts.hpp"

#include <indurop/module_abi.h>

#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace irp::hosts {

// The property every thread module gets besides its own: the absolute folder of its module.xml,
// against which it resolves the relative file names of its other properties.
inline constexpr const char *kSetDirProperty = "indurop.set_dir";

// Whether a module built against layout `built` ("": it uses no shared variables) may run on
// `layout` (null: the set has no shared variables): Ok, or the refusal placed at the module's file
// ("rebuild it against the set's .glb files").  The one rule for thread and process modules, asked
// by the reloader's plan before anything loads (so that `check` refuses what `load` would) and by
// ThreadModule::load.
Status builtLayoutFits(const config::ModuleSpec &spec, std::string_view built, const layouts::Model *layout);

class ThreadModule {
public:
    // dlopen(RTLD_NOW) the module's file and resolve its entry points.  Refuses a missing file,
    // a library the loader rejects (unresolved symbol, wrong architecture...), a module without
    // run, a descriptor of an unknown ABI version, and a module built against another layout of
    // shared variables than `layout_hash` (the running segment's; null = the set has none).
    // `image`, if given, is the file actually loaded: a content-addressed copy of spec.path
    // (hosts/module_cache.hpp), so that a changed module is really its new code; messages name
    // spec.path.
    static Result<std::unique_ptr<ThreadModule>> load(const config::ModuleSpec &spec, const char *layout_hash = nullptr,
                                                      const std::filesystem::path &image = {});
    // The same against a layout model: a module built against a layout of its lineage whose
    // variables are all in place is accepted too (layouts::compatible).  Null: no shared variables.
    static Result<std::unique_ptr<ThreadModule>> load(const config::ModuleSpec &spec, const layouts::Model *layout,
                                                      const std::filesystem::path &image = {});
    // This load of the module (its exports and the finds of its initialize()/start() are recorded under it).
    uint64_t instance() const { return instance_; }
    // The layout hash stamped into the module ("" when it uses no shared variables).
    const std::string &builtLayout() const { return built_layout_; }

    ~ThreadModule();  // dlclose
    ThreadModule(const ThreadModule &) = delete;
    ThreadModule &operator=(const ThreadModule &) = delete;

    // The module's source in the alarm segment (docs/alarms.md): its initialize() and start()
    // raise and declare alarms there.  Set before initialize(); none by default.
    void setAlarmSource(uint32_t source) { alarm_source_ = source; }
    uint32_t alarmSource() const { return alarm_source_; }

    // initialize(properties) then start(): non-RT, before dispatching.  The Error names the module.
    // initialize() first registers module.xml's <alarm>s as the instance's declarations
    // (runtime::declareAlarms), which irp::declareAlarm in either adds to.
    Status initialize();
    Status start();
    // stop(): non-RT, after the last run().  Calls the module's stop() once, and only after a
    // successful start(); a throw from it comes back as the Error.
    Status stop();

    void (*runFunction() const)() { return table_.run; }
    // The optional extern "C" safe_outputs() (either style): drives the module's outputs to safe
    // values when a fault stops the set.  Called from a non-RT thread while run() may still be
    // running on the RT thread (docs/modules.md); an Error if it threw.  No hook: Ok, nothing done.
    bool hasSafeOutputs() const { return safe_outputs_ != nullptr; }
    Status safeOutputs() const;
    bool hasCondition() const { return table_.condition != nullptr; }
    int condition() const { return table_.condition(); }

    const std::string &name() const { return spec_.name; }
    const config::ModuleSpec &spec() const { return spec_; }
    const indurop_module_v1 &table() const { return table_; }
    bool usesDescriptor() const { return descriptor_; }
    bool started() const { return started_; }
    // What its run() or condition() last threw, written by its executor (for the `fault` event).
    dispatch::FaultNote &faultNote() { return fault_note_; }
    const dispatch::FaultNote &faultNote() const { return fault_note_; }

private:
    explicit ThreadModule(const config::ModuleSpec &spec);
    Status call(const char *what, const std::function<int(char *err, std::size_t size)> &fn) const;

    config::ModuleSpec spec_;
    uint64_t instance_;  // unique per load: owns the shared functions its initialize()/start() export
    uint32_t alarm_source_;
    void *handle_ = nullptr;
    int code_entry_ = -1;  // its address range for the crash handler (supervise/module_code.hpp)
    bool descriptor_ = false;
    bool started_ = false;
    std::string built_layout_;
    indurop_module_v1 table_{};
    // initialize() and start() of either style, as the descriptor's signature: 0 or an error in
    // `err`.  A plain module's C++ hooks are wrapped so (their throw is the error); empty: none.
    std::function<int(const indurop_property_list *, char *err, std::size_t)> initialize_;
    std::function<int(char *err, std::size_t)> start_;
    void (*safe_outputs_)() = nullptr;
    std::vector<indurop_property_entry> property_entries_;
    dispatch::FaultNote fault_note_;
};

}  // namespace irp::hosts
