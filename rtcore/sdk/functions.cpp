// functions.cpp -- the registry of shared functions (see <indurop/functions.h>): name -> function
// pointer, its signature, the module that exported it and, for calls from processes, its thunk.
// Used only at start-up and unload, never on the RT path, so a mutex and a map are fine here.
#include <indurop/functions.h>

#include "runtime.hpp"

#include <cxxabi.h>

#include <cstdlib>
#include <map>
#include <memory>
#include <mutex>
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
std::map<std::string, Export> g_exports;
thread_local std::string g_current_module;  // the module whose initialize()/start() is running
thread_local uint64_t g_current_instance = 0;

std::string readable(const std::string &mangled) {
    int status = 0;
    std::unique_ptr<char, void (*)(void *)> text(abi::__cxa_demangle(mangled.c_str(), nullptr, nullptr, &status), std::free);
    return status == 0 && text ? text.get() : mangled;
}

} // namespace

namespace detail {

void exportFunction(const char *name, AnyFunction fn, const char *signature) {
    exportFunction(name, fn, signature, CallShape{});  // a module built before calls from processes
}

void exportFunction(const char *name, AnyFunction fn, const char *signature, const CallShape &shape) {
    if (!name || !*name) throw FunctionError("exportFunction: the name is empty");
    if (!fn) throw FunctionError(std::string("exportFunction(\"") + name + "\"): the function is null");
    std::lock_guard lock(g_mutex);
    auto [it, fresh] = g_exports.emplace(name, Export{fn, signature, g_current_module, g_current_instance, shape});
    if (!fresh)
        throw FunctionError(std::string("shared function '") + name + "' is exported twice (first by module '" +
                            it->second.owner + "')");
}

AnyFunction findFunction(const char *name, const char *signature) {
    std::lock_guard lock(g_mutex);
    auto it = g_exports.find(name ? name : "");
    if (it == g_exports.end())
        throw FunctionError(std::string("no module exports a shared function '") + (name ? name : "") +
                            "' (export in initialize(), find in start())");
    if (it->second.signature != signature)
        throw FunctionError(std::string("shared function '") + name + "' of module '" + it->second.owner + "' is " +
                            readable(it->second.signature) + ", not " + readable(signature));
    return it->second.fn;
}

} // namespace detail

namespace runtime {

void setCurrentModule(const std::string &name, uint64_t instance) {
    g_current_module = name;
    g_current_instance = instance;
}

void dropFunctionsOf(uint64_t instance) {
    std::lock_guard lock(g_mutex);
    for (auto it = g_exports.begin(); it != g_exports.end();)
        it = it->second.instance == instance ? g_exports.erase(it) : std::next(it);
}

std::size_t exportedFunctions() {
    std::lock_guard lock(g_mutex);
    return g_exports.size();
}

std::vector<FunctionExport> functionExports() {
    std::lock_guard lock(g_mutex);
    std::vector<FunctionExport> list;
    list.reserve(g_exports.size());
    for (const auto &[name, e] : g_exports) list.push_back({name, e.signature, e.owner, e.fn, e.shape});
    return list;
}

} // namespace runtime
} // namespace irp
