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
//
// From a process module (an executable started by irpd) a call goes through irpd: the process
// writes a request into its call area in the control segment (<indurop/control.h>) and waits; the
// dispatcher serves it right after the owner's run(), in the owner's slot, on the owner's thread:
//
//     irp::SharedFunction<double(double)> scale("A.scale");      // resolved at its first call
//     double y;
//     if (scale(&y, 2'000'000, 4.0) != 0)                        // timeout 2 ms
//         std::fprintf(stderr, "%s\n", irp::lastCallError());
//     // or, the signature deduced from the arguments (4.0 is a double, so double(double)):
//     irp::callFunction("A.scale", &y, 2'000'000, 4.0);
//
// The contract (docs/shared-variables.md, "Shared functions"):
//   - callable: functions of periodic thread modules whose result and parameters are trivially
//     copyable values (const T& parameters are passed as T; no pointers, no T&), INDUROP_CALL_BYTES
//     (256) bytes at most each way, parameters packed back to back in order;
//   - served within the owner's period: right after the owner's run() in its slot, at most
//     irp::kCallsServedPerPeriod requests per owner per period (the rest wait for its next period);
//     the owner's exec time includes the serving;
//   - a call returns 0 with *result set, or -1 and irp::lastCallError() / irp::lastCallStatus()
//     say why: unknown name, signature differs (checked by the process against the table and by
//     irpd against the export), too large, owner not periodic (answered at once, no request
//     sent), owner disabled (answered by irpd in the owner's slot), the function threw (its
//     message), timeout, irpd stopping, not started by irpd.  It never waits past its timeout;
//   - one call in flight per process: calls from several threads of one process take turns (a
//     mutex, waited for within the same timeout);
//   - RT safety: the first call maps the control segment (allocates); after that a call is a
//     linear scan of the table by name (a SharedFunction: once), a few stores, a futex wait.  A
//     periodic process awaited by the same executor as the owner blocks its own slot while it
//     waits: call from a sporadic or non-real process, or from another executor's.
#pragma once

#include <indurop/control.h>

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <typeinfo>
#include <utility>

namespace irp {

class FunctionError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Requests irpd serves for one owner module per period, at most.
inline constexpr unsigned kCallsServedPerPeriod = 8;
// Packed argument bytes, and result bytes, of a call from a process, at most.
inline constexpr std::size_t kCallBytes = INDUROP_CALL_BYTES;

namespace detail {
using AnyFunction = void (*)();

// Calls fn with the arguments packed in args and writes the result's bytes to result.
using Thunk = void (*)(AnyFunction fn, const unsigned char *args, unsigned char *result);

// What a process needs to call an export: its thunk (null when its types cannot cross a process
// boundary) and the packed sizes.
struct CallShape {
    Thunk thunk = nullptr;
    uint32_t args_size = 0;
    uint32_t result_size = 0;
};

// Registry in libindurop; `signature` is the mangled name of the function type.
void exportFunction(const char *name, AnyFunction fn, const char *signature);
void exportFunction(const char *name, AnyFunction fn, const char *signature, const CallShape &shape);
AnyFunction findFunction(const char *name, const char *signature);

// A parameter or result that can be sent as bytes to another process: a trivially copyable value,
// or a const reference to one; never a pointer (it would point into the wrong address space).
// (A type incomplete where the function is exported -- a reference to an opaque type -- is not:
// such a function stays callable between thread modules only.)
template <class T, class = void>
inline constexpr bool kComplete = false;
template <class T>
inline constexpr bool kComplete<T, std::void_t<decltype(sizeof(T))>> = true;

template <class T>
constexpr bool transferable() {
    using U = std::remove_cvref_t<T>;
    if constexpr (std::is_reference_v<T> && !std::is_const_v<std::remove_reference_t<T>>)
        return false;
    else if constexpr (std::is_pointer_v<U> || std::is_member_pointer_v<U> || std::is_array_v<U> || std::is_void_v<U>)
        return false;
    else if constexpr (!kComplete<U>)
        return false;
    else
        return std::is_trivially_copyable_v<U>;
}
template <class T>
inline constexpr bool kTransferable = transferable<T>();
template <class R>
inline constexpr bool kTransferableResult = std::is_void_v<R> || (!std::is_reference_v<R> && kTransferable<R>);

template <class... A>
inline constexpr std::size_t kPackedSize = (std::size_t{0} + ... + sizeof(std::remove_cvref_t<A>));

template <class T>
std::size_t packOne(unsigned char *out, std::size_t at, const T &value) noexcept {
    std::memcpy(out + at, &value, sizeof(T));
    return at + sizeof(T);
}

// Writes the arguments back to back, in order, without padding.
template <class... A>
void pack(unsigned char *out, const A &...args) noexcept {
    std::size_t at = 0;
    ((at = packOne(out, at, args)), ...);
    (void)at;
    (void)out;  // no arguments
}

template <class T>
T unpackOne(const unsigned char *in) noexcept {
    struct Bytes {
        unsigned char b[sizeof(T)];
    } bytes;
    std::memcpy(bytes.b, in, sizeof(T));
    return std::bit_cast<T>(bytes);
}

// Where argument I starts in the packed bytes: the sizes of the arguments before it.
template <std::size_t I, class... A>
constexpr std::size_t packedOffset() {
    const std::size_t sizes[] = {sizeof(std::remove_cvref_t<A>)..., 0};
    std::size_t at = 0;
    for (std::size_t k = 0; k < I; ++k) at += sizes[k];
    return at;
}
template <std::size_t I, class... A>
inline constexpr std::size_t kPackedOffset = packedOffset<I, A...>();

template <class R, class... A, std::size_t... I>
void invokePacked(AnyFunction f, const unsigned char *args, unsigned char *result, std::index_sequence<I...>) {
    auto fn = reinterpret_cast<R (*)(A...)>(f);
    if constexpr (std::is_void_v<R>) {
        fn(unpackOne<std::remove_cvref_t<A>>(args + kPackedOffset<I, A...>)...);
        (void)args;
        (void)result;
    } else {
        const R r = fn(unpackOne<std::remove_cvref_t<A>>(args + kPackedOffset<I, A...>)...);
        std::memcpy(result, &r, sizeof(R));
    }
}

template <class R, class... A>
void thunkOf(AnyFunction f, const unsigned char *args, unsigned char *result) {
    invokePacked<R, A...>(f, args, result, std::index_sequence_for<A...>{});
}

template <class R, class... A>
constexpr CallShape callShapeOf() {
    if constexpr (kTransferableResult<R> && (kTransferable<A> && ...)) {
        constexpr std::size_t result_size = [] {
            if constexpr (std::is_void_v<R>)
                return std::size_t{0};
            else
                return sizeof(R);
        }();
        return CallShape{&thunkOf<R, A...>, static_cast<uint32_t>(kPackedSize<A...>),
                         static_cast<uint32_t>(result_size)};
    } else {
        return CallShape{};
    }
}
}  // namespace detail

// Exports fn under name for the other thread modules of the set, and -- when its types can cross a
// process boundary -- for process modules through irpd.
template <class R, class... A>
void exportFunction(const char *name, R (*fn)(A...)) {
    detail::exportFunction(name, reinterpret_cast<detail::AnyFunction>(fn), typeid(R(A...)).name(),
                           detail::callShapeOf<R, A...>());
}

template <class Signature>
Signature *findFunction(const char *name) {
    return reinterpret_cast<Signature *>(detail::findFunction(name, typeid(Signature).name()));
}

// ---- calls from process modules ----------------------------------------------------------------

// Why the calling thread's last call from a process failed ("" after a success), and its
// enum indurop_call_status (0 after a success).  Per thread; valid until its next call.
const char *lastCallError() noexcept;
int lastCallStatus() noexcept;

namespace detail {
// The call machinery in libindurop (sdk/calls.cpp).  resolve: the table index of name, after
// checking the signature and sizes against the export; -1 on failure (lastCallError set).
int resolveFunction(const char *name, const char *signature, uint32_t args_size, uint32_t result_size,
                    uint32_t *index) noexcept;
int callResolved(uint32_t index, const char *signature, const void *args, uint32_t args_size, void *result,
                 uint32_t result_size, int64_t timeout_ns) noexcept;
int failCall(int status, const char *message) noexcept;  // sets lastCallError/Status, returns -1
}  // namespace detail

template <class Signature>
class SharedFunction;

// A shared function of a thread module, called from a process module through irpd.  Resolved by
// name in irpd's function table at its first call (and again after a failed resolution); one
// object per function, kept across periods.  Not for thread modules: they use findFunction.
template <class R, class... A>
class SharedFunction<R(A...)> {
    static_assert(detail::kTransferableResult<R> && (detail::kTransferable<A> && ...),
                  "a shared function called from a process takes and returns trivially copyable values "
                  "(const T& is passed as a T): no pointers, no T&, no std::string or containers");

public:
    explicit SharedFunction(const char *name) noexcept : name_(name) {}

    // Calls the function with args and waits at most timeout_ns (> 0) for the answer.  Returns 0
    // with *result set (for R = void pass nullptr), or -1: see lastCallError().
    int operator()(R *result, int64_t timeout_ns, A... args) noexcept {
        constexpr std::size_t args_size = detail::kPackedSize<A...>;
        constexpr std::size_t result_size = [] {
            if constexpr (std::is_void_v<R>)
                return std::size_t{0};
            else
                return sizeof(R);
        }();
        if constexpr (args_size > kCallBytes || result_size > kCallBytes) {
            char text[200];
            std::snprintf(text, sizeof text,
                          "shared function '%s': %s %zu bytes, more than the %zu a call from a process carries", name_,
                          args_size > kCallBytes ? "its arguments are" : "its result is",
                          args_size > kCallBytes ? args_size : result_size, kCallBytes);
            ((void)args, ...);
            return detail::failCall(INDUROP_CALL_TOO_LARGE, text);
        } else {
            if (!resolved_ &&
                detail::resolveFunction(name_, typeid(R(A...)).name(), args_size, result_size, &index_) != 0)
                return -1;
            resolved_ = true;
            unsigned char packed[args_size ? args_size : 1];
            detail::pack(packed, args...);
            if constexpr (std::is_void_v<R>) {
                (void)result;
                return detail::callResolved(index_, typeid(R(A...)).name(), packed, args_size, nullptr, 0, timeout_ns);
            } else {
                if (!result) return detail::failCall(INDUROP_CALL_INVALID, "the result pointer is null");
                unsigned char out[result_size];
                if (detail::callResolved(index_, typeid(R(A...)).name(), packed, args_size, out, result_size,
                                         timeout_ns) != 0)
                    return -1;
                std::memcpy(static_cast<void *>(result), out, result_size);
                return 0;
            }
        }
    }

    const char *name() const noexcept { return name_; }

private:
    const char *name_;
    uint32_t index_ = 0;
    bool resolved_ = false;
};

// The same in one call, the signature deduced from the arguments and result: R(A...) with each
// argument's type as written at the call site (4 is an int, 4.0 a double, a `const Pose&` parameter
// needs SharedFunction<R(const Pose&)>).  Resolves the name at every call (a table scan).
template <class R, class... A>
int callFunction(const char *name, R *result, int64_t timeout_ns, A... args) noexcept {
    return SharedFunction<R(A...)>(name)(result, timeout_ns, args...);
}
// A function returning void: callFunction("cell.reset", nullptr, timeout, args...).
template <class... A>
int callFunction(const char *name, std::nullptr_t, int64_t timeout_ns, A... args) noexcept {
    return SharedFunction<void(A...)>(name)(nullptr, timeout_ns, args...);
}

}  // namespace irp
