// thread_module.cpp -- dlopen-based loading and the lifecycle of thread modules.
#include "hosts/thread_module.hpp"

#include "protocol/limits.hpp"

#include <indurop/property.h>

#include "dispatch/running_marker.hpp"
#include "sdk/runtime.hpp"
#include "supervise/module_code.hpp"

#include <dlfcn.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstring>
#include <exception>
#include <system_error>

namespace irp::hosts {
namespace {

std::string who(const config::ModuleSpec &spec) { return "module '" + spec.name + "'"; }

// An error in a module's shared object: "module 'x': what", placed at the .so.
Error inObject(const config::ModuleSpec &spec, const std::string &what) {
    return Error{who(spec) + ": " + what, protocol::kRefused, Place{spec.path.string(), 0, 0, spec.name, {}}};
}

std::string lastDlError() {
    const char *e = dlerror();
    return e ? e : "unknown loader error";
}

}  // namespace

Status builtLayoutFits(const config::ModuleSpec &spec, std::string_view built, const layouts::Model *layout) {
    if (built.empty()) return Ok{};
    if (!layout)
        return inObject(spec, spec.path.string() + " uses shared variables (layout " + std::string(built) +
                                  ") but the set declares no <layout>");
    if (std::string why = layouts::compatible(built, *layout); !why.empty())
        return inObject(spec, spec.path.string() + ": " + why);
    return Ok{};
}

ThreadModule::ThreadModule(const config::ModuleSpec &spec) : spec_(spec), alarm_source_(runtime::kNoAlarmSource) {
    static std::atomic<uint64_t> loads{0};
    instance_ = ++loads;
}

Result<std::unique_ptr<ThreadModule>> ThreadModule::load(const config::ModuleSpec &spec, const char *layout_hash,
                                                         const std::filesystem::path &image) {
    if (!layout_hash) return load(spec, static_cast<const layouts::Model *>(nullptr), image);
    layouts::Model exact;  // no lineage: only this very layout
    exact.self.hash = layout_hash;
    return load(spec, &exact, image);
}

Result<std::unique_ptr<ThreadModule>> ThreadModule::load(const config::ModuleSpec &spec, const layouts::Model *layout,
                                                         const std::filesystem::path &image) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(spec.path, ec))
        return config::errorAbout(spec, "<filename> " + spec.filename + " -> " + spec.path.string() + " does not exist",
                                  "filename");

    std::unique_ptr<ThreadModule> module(new ThreadModule(spec));
    dlerror();
    const std::filesystem::path &file = image.empty() ? spec.path : image;
    module->handle_ = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!module->handle_) return inObject(spec, "cannot load " + spec.path.string() + ": " + lastDlError());
    // Its address range, for a crash record that names the faulting instruction's source line.
    module->code_entry_ =
        supervise::registerModuleCode(module->handle_, spec.name, std::filesystem::absolute(file).string());

    // Built with <indurop/generated.h>: the layout it was compiled against must be the one it will
    // run on, or one that layout was laid out against with its variables in place (layouts.hpp).
    if (const auto *built = static_cast<const char *>(dlsym(module->handle_, "indurop_layout_hash"))) {
        if (Status st = builtLayoutFits(spec, built, layout); !st) return st.error();
        module->built_layout_ = built;
    }
    dlerror();

    if (void *sym = dlsym(module->handle_, INDUROP_MODULE_DESCRIPTOR_SYMBOL)) {
        auto descriptor = reinterpret_cast<indurop_module_descriptor_fn>(sym);
        const indurop_module_v1 *table = descriptor();
        if (!table || table->abi_version != INDUROP_MODULE_ABI_VERSION ||
            table->struct_size < sizeof(indurop_module_v1))
            return inObject(spec, spec.path.string() + " was built for module ABI version " +
                                      std::to_string(table ? table->abi_version : 0) + "; this irpd runs version " +
                                      std::to_string(INDUROP_MODULE_ABI_VERSION) + ": rebuild it against this SDK");
        module->table_ = *table;
        module->descriptor_ = true;
        if (table->initialize) module->initialize_ = table->initialize;
        if (table->start) module->start_ = table->start;
        if (!module->table_.run)
            return inObject(spec, "INDUROP_MODULE(...) in " + spec.path.string() +
                                      " sets no run; write INDUROP_MODULE(run = &::yourFunction)");
    } else {
        dlerror();
        module->table_.abi_version = INDUROP_MODULE_ABI_VERSION;
        module->table_.struct_size = sizeof(indurop_module_v1);
        module->table_.run = reinterpret_cast<void (*)()>(dlsym(module->handle_, "run"));
        if (!module->table_.run)
            return inObject(spec, spec.path.string() + " has neither INDUROP_MODULE(...) nor an extern \"C\" run() (" +
                                      lastDlError() + ")");
        module->table_.stop = reinterpret_cast<void (*)()>(dlsym(module->handle_, "stop"));
        module->table_.condition = reinterpret_cast<int (*)()>(dlsym(module->handle_, "condition"));
        // extern "C" initialize(irp::Property const &) and start(): their throw is their error.
        if (void *init = dlsym(module->handle_, "initialize"))
            module->initialize_ = [f = reinterpret_cast<void (*)(irp::Property const &)>(init)](
                                      const indurop_property_list *list, char *, std::size_t) {
                f(irp::Property(list));
                return 0;
            };
        if (void *start = dlsym(module->handle_, "start"))
            module->start_ = [f = reinterpret_cast<void (*)()>(start)](char *, std::size_t) {
                f();
                return 0;
            };
        dlerror();
    }
    module->safe_outputs_ = reinterpret_cast<void (*)()>(dlsym(module->handle_, "safe_outputs"));
    dlerror();
    for (const auto &[name, value] : module->spec_.properties)
        module->property_entries_.push_back({name.c_str(), value.c_str()});
    // Where the set's other files are (ioconfig.xml, a URDF...): a module is loaded from a copy in
    // the module cache, so its own location says nothing about them.
    module->property_entries_.push_back({kSetDirProperty, module->spec_.set_dir.c_str()});
    return module;
}

ThreadModule::~ThreadModule() {
    runtime::dropFunctionsOf(instance_);  // its exports point into the code about to go
    runtime::dropAlarmsOf(instance_);
    supervise::unregisterModuleCode(code_entry_);
    if (handle_) dlclose(handle_);
}

namespace {
// Marks whose lifecycle function the main thread is in, so that a crash in it is recorded
// against it (dispatch/running_marker.hpp).
struct LifecycleMark {
    explicit LifecycleMark(const std::string &name) {
        dispatch::RunningMarker &m = dispatch::g_running_markers[dispatch::kLifecycleMarker];
        std::snprintf(m.executor, sizeof m.executor, "%s", "lifecycle");
        m.tid.store(static_cast<int>(syscall(SYS_gettid)), std::memory_order_relaxed);
        m.module.store(name.c_str(), std::memory_order_relaxed);
    }
    ~LifecycleMark() {
        dispatch::g_running_markers[dispatch::kLifecycleMarker].module.store(nullptr, std::memory_order_relaxed);
    }
};

// Marks whose initialize()/start() runs, so that its shared-function exports and its alarms are
// its own.
struct CurrentModule {
    CurrentModule(const std::string &name, uint64_t instance, uint32_t alarm_source) : mark(name) {
        runtime::setCurrentModule(name, instance);
        runtime::setAlarmSource(alarm_source);
    }
    ~CurrentModule() {
        runtime::setCurrentModule("");
        runtime::setAlarmSource(runtime::kNoAlarmSource);
    }
    LifecycleMark mark;
};
}  // namespace

// One lifecycle call of the module on the main thread: the error it reports in `err` (a nonzero
// return) or a C++ exception it lets out is the Error, "<what> failed: <why>".
Status ThreadModule::call(const char *what, const std::function<int(char *err, std::size_t size)> &fn) const {
    char err[512] = "";
    const auto failed = [&](const std::string &why) {
        return Error{who(spec_) + ": " + what + why, protocol::kRefused, Place{{}, 0, 0, spec_.name, {}}};
    };
    try {
        if (fn(err, sizeof err) == 0) return Ok{};
    } catch (const std::exception &e) {
        return failed(std::string(" failed: ") + e.what());
    } catch (...) {
        return failed(" threw a non-standard exception");
    }
    return failed(std::string(" failed: ") + err);
}

Status ThreadModule::initialize() {
    std::vector<runtime::AlarmDeclaration> declared;
    for (const config::AlarmSpec &a : spec_.alarms) declared.push_back({a.id, a.severity, a.text, false});
    runtime::declareAlarms(instance_, std::move(declared));
    CurrentModule current(spec_.name, instance_, alarm_source_);
    if (!initialize_) return Ok{};
    const indurop_property_list list{property_entries_.data(), property_entries_.size()};
    return call("initialize()", [&](char *err, std::size_t size) { return initialize_(&list, err, size); });
}

Status ThreadModule::start() {
    CurrentModule current(spec_.name, instance_, alarm_source_);
    if (start_)
        if (Status st = call("start()", start_); !st) return st;
    started_ = true;
    return Ok{};
}

Status ThreadModule::safeOutputs() const {
    if (!safe_outputs_) return Ok{};
    return call("safe_outputs()", [this](char *, std::size_t) {
        safe_outputs_();
        return 0;
    });
}

Status ThreadModule::stop() {
    if (!started_) return Ok{};
    started_ = false;
    if (!table_.stop) return Ok{};
    LifecycleMark mark(spec_.name);
    return call("stop()", [this](char *, std::size_t) {
        table_.stop();
        return 0;
    });
}

}  // namespace irp::hosts
