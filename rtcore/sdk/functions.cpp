// functions.cpp -- the registry of shared functions (see <indurop/functions.h>): name -> function
// pointer, its signature, the module that exported it and, for calls from processes, its thunk.
// Used only at start-up and unload, never on the RT path, so a mutex and a map are fine here.
//
// During a hot reload that replaces an exporter, its new instance exports the same names while the
// old one still runs: the newest export of a name is the one found, and the old one goes when its
// module is unloaded.  Each find is recorded (who found whose function), so that the reloader
// knows which kept modules hold pointers into an exporter that would go away.
#include <indurop/functions.h>

#include "runtime.hpp"

#include <cxxabi.h>

#include <cstdlib>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <vector>
#include <string>

namespace irp {
namespace {

struct Export {
    detail::AnyFunction fn;
    std::string signature;
    std::string owner;
    uint64_t instance = 0;    // the owner's load (see runtime::setCurrentModule)
    detail::CallShape shape;  // no thunk: not callable from processes
};

std::mutex g_mutex;
std::map<std::string, std::vector<Export>> g_exports;  // per name, oldest first
std::multimap<uint64_t, uint64_t> g_imports;           // exporter instance -> importer instance
thread_local std::string g_current_module;             // the module whose initialize()/start() is running
thread_local uint64_t g_current_instance = 0;

std::string readable(const std::string &mangled) {
    int status = 0;
    std::unique_ptr<char, void (*)(void *)> text(abi::__cxa_demangle(mangled.c_str(), nullptr, nullptr, &status),
                                                 std::free);
    return status == 0 && text ? text.get() : mangled;
}

}  // namespace

namespace detail {

void exportFunction(const char *name, AnyFunction fn, const char *signature) {
    exportFunction(name, fn, signature, CallShape{});  // a module built before calls from processes
}

void exportFunction(const char *name, AnyFunction fn, const char *signature, const CallShape &shape) {
    if (!name || !*name) throw FunctionError("exportFunction: the name is empty");
    if (!fn) throw FunctionError(std::string("exportFunction(\"") + name + "\"): the function is null");
    std::lock_guard lock(g_mutex);
    std::vector<Export> &list = g_exports[name];
    for (const Export &e : list)  // only a new instance of the same module may export the name again
        if (e.owner != g_current_module || e.instance == g_current_instance || g_current_module.empty())
            throw FunctionError(std::string("shared function '") + name + "' is exported twice (first by module '" +
                                e.owner + "')");
    list.push_back(Export{fn, signature, g_current_module, g_current_instance, shape});
}

AnyFunction findFunction(const char *name, const char *signature) {
    std::lock_guard lock(g_mutex);
    auto it = g_exports.find(name ? name : "");
    if (it == g_exports.end() || it->second.empty())
        throw FunctionError(std::string("no module exports a shared function '") + (name ? name : "") +
                            "' (export in initialize(), find in start())");
    const Export &e = it->second.back();
    if (e.signature != signature)
        throw FunctionError(std::string("shared function '") + name + "' of module '" + e.owner + "' is " +
                            readable(e.signature) + ", not " + readable(signature));
    if (g_current_instance) g_imports.emplace(e.instance, g_current_instance);
    return e.fn;
}

}  // namespace detail

namespace runtime {

void setCurrentModule(const std::string &name, uint64_t instance) {
    g_current_module = name;
    g_current_instance = instance;
}

uint64_t currentModuleInstance() noexcept { return g_current_instance; }

void dropFunctionsOf(uint64_t instance) {
    std::lock_guard lock(g_mutex);
    for (auto it = g_exports.begin(); it != g_exports.end();) {
        std::erase_if(it->second, [&](const Export &e) { return e.instance == instance; });
        it = it->second.empty() ? g_exports.erase(it) : std::next(it);
    }
    g_imports.erase(instance);
    std::erase_if(g_imports, [&](const auto &edge) { return edge.second == instance; });
}

std::size_t exportedFunctions() {
    std::lock_guard lock(g_mutex);
    return g_exports.size();
}

std::vector<FunctionExport> functionExports() {
    std::lock_guard lock(g_mutex);
    std::vector<FunctionExport> list;
    list.reserve(g_exports.size());
    for (const auto &[name, versions] : g_exports) {
        const Export &e = versions.back();
        list.push_back({name, e.signature, e.owner, e.fn, e.shape});
    }
    return list;
}

std::vector<std::string> exportsOf(uint64_t instance) {
    std::lock_guard lock(g_mutex);
    std::vector<std::string> names;
    for (const auto &[name, versions] : g_exports)
        for (const Export &e : versions)
            if (e.instance == instance) names.push_back(name);
    return names;
}

std::set<uint64_t> importersOf(uint64_t instance) {
    std::lock_guard lock(g_mutex);
    std::set<uint64_t> out;
    for (auto [it, end] = g_imports.equal_range(instance); it != end; ++it)
        if (it->second != instance) out.insert(it->second);
    return out;
}

}  // namespace runtime
}  // namespace irp
