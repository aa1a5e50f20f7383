// functions.h -- shared functions (paper §3): a module exports named functions that other modules
// call.
//
// Between thread modules (all in irpd's process) a call is a direct call through a function
// pointer, found once by name:
//
//     // in module A
//     double scale(double v) { return v * gain; }
//     bool onInit(irp::Property const &) { irp::exportFunction("A.scale", &scale); return true; }
//
//     // in module B
//     double (*scale)(double) = nullptr;
//     void onStart() { scale = irp::findFunction<double(double)>("A.scale"); }
//     void onRun()   { y = scale(x); }          // an ordinary call, on B's RT thread
//
// The contract:
//   - export in initialize() (or start()); find in start(): every module of a set is initialized
//     before any is started, so start() sees every export of the set;
//   - the signature is part of the name: findFunction with another signature than the export's
//     throws irp::FunctionError naming both, so a mismatch refuses the set at start-up instead of
//     corrupting the stack at run time; an unknown name throws too;
//   - a name is exported once per set (a second export throws); exports disappear when their
//     module is unloaded (irpd stops every module that could hold the pointer first);
//   - the call runs on the caller's thread, in the caller's slot: the function must be RT safe if
//     the caller calls it from run(), and must protect its own state if several callers use it.
#pragma once

#include <stdexcept>
#include <string>
#include <typeinfo>

namespace irp {

class FunctionError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

namespace detail {
using AnyFunction = void (*)();
// Registry in libindurop; `signature` is the mangled name of the function type.
void exportFunction(const char *name, AnyFunction fn, const char *signature);
AnyFunction findFunction(const char *name, const char *signature);
} // namespace detail

template <class R, class... A>
void exportFunction(const char *name, R (*fn)(A...)) {
    detail::exportFunction(name, reinterpret_cast<detail::AnyFunction>(fn), typeid(R(A...)).name());
}

template <class Signature>
Signature *findFunction(const char *name) {
    return reinterpret_cast<Signature *>(detail::findFunction(name, typeid(Signature).name()));
}

} // namespace irp
