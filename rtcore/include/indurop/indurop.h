// indurop.h -- the module SDK: what a thread module includes to be loaded and run by irpd.
//
// Two ways to write a thread module, both source-compatible with the paper:
//
//   1. A descriptor (Figures 4, 5):
//        void onRun() { ... }
//        INDUROP_MODULE(name = "cntr", description = "...", author = "...", license = "MIT",
//                       initialize = &::onInit, start = &::onStart, run = &::onRun,
//                       stop = &::onStop, condition = &::onCondition)
//      Only `run` is required.  initialize may take (irp::Property const&) or nothing and return
//      void, bool (false = refuse) or int (non-zero = refuse); start likewise without arguments;
//      condition returns int or bool.  Name each function with `&::` as the paper does.
//
//   2. Plain entry points (Figures 7, 12): define any of
//        extern "C" void initialize(irp::Property const&);  void start();  void run();
//        void stop();  int condition();
//      This header declares them extern "C", so definitions that follow it get C linkage even
//      when written without `extern "C"` (as in Figure 12).  Define INDUROP_NO_PLAIN_ENTRY_POINTS
//      before including to keep those names free.  A module with a descriptor uses only it.
//
// Lifecycle, driven by irpd:
//   load (dlopen) -> initialize(properties of module.xml)      non-RT thread, may allocate/block
//                 -> start()                                    non-RT thread, may allocate/block
//                 -> run() every period                         RT thread: see the rules below
//                 -> stop()                                     non-RT thread, after the last run()
//                 -> unload (dlclose)
// A throw from initialize() or start() (irp::PropertyError for a bad property, or any
// std::exception) refuses the module and the set does not start; the message is shown to the user.
//
// Inside run() (and condition()) a module runs on the dispatcher's SCHED_FIFO thread, inside a
// slot of the basic period, in priority order.  It must be real-time safe:
//   - no allocation (new, malloc, std::string/std::vector growth), no locks that a non-RT thread
//     may hold, no blocking I/O, no sleeping, no syscalls that may block;
//   - bounded and short: the slot's whole work must fit the basic period, or irpd counts an
//     overrun (and a module exceeding its <budget> counts one of its own);
//   - irp::printf is safe (it formats into a lock-free ring drained by a non-RT thread);
//   - do not throw: a throw out of run() is caught, counted and the module is disabled.
#pragma once

#include <indurop/module_abi.h>
#include <indurop/functions.h>
#include <indurop/property.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <tuple>
#include <type_traits>

namespace irp {

// printf that is safe on the RT thread: formats into a fixed-size entry (at most 239 characters
// are kept) of a lock-free ring that irpd's non-RT thread writes to its log.  Returns the number
// of characters kept, or -1 when the ring was full and the line was dropped (irpd counts drops).
int printf(const char *format, ...) __attribute__((format(printf, 1, 2)));

// Where the dispatcher stands while run() executes.
struct Cycle {
    uint64_t count;      // basic periods since the set started (0, 1, 2, ...)
    uint32_t slot;       // index in the slot table (count % number of slots)
    int64_t planned_ns;  // CLOCK_MONOTONIC time at which this basic period was due
    int64_t basic_ns;    // the basic period
};

// The cycle of the calling dispatcher thread; all zero outside run().
const Cycle &cycle() noexcept;

// Whether the run in progress must end now: true once the overrun watchdog found the calling
// thread module's current run() past its <overrun_limit> and its <on_overrun> is `disable` or
// `stop` (docs/faults.md); false again from its next run on, and always false elsewhere (no limit
// watched, `warn` or `skip`, condition(), a thread the module started, a process module).  It
// costs a call and three loads (no syscall, no lock, no atomic read-modify-write), so a long loop
// may poll it on every iteration and end the run: return, or throw std::runtime_error("why") --
// the module is then disabled and the `fault` event carries the text.
bool runAbortRequested() noexcept;

// ---- alarms (docs/alarms.md; the segment's layout: <indurop/alarms.h>) --------------------------
// An alarm of a module is its id, 1 .. 1023, with a text and a severity declared in module.xml
// (<alarm id="8" severity="high">drive communication lost</alarm>) or by declareAlarm().  The
// agent keeps each alarm's state for the operators (active, acknowledged, cleared, shelved) and
// its history.  The same calls work in process modules (through the segment irpd names in
// INDUROP_ALARMS).
enum class Severity : uint8_t { Declared = 0, Low = 1, Medium = 2, High = 3, Critical = 4 };

// Raises alarm `id` of the calling module, with an optional detail text (at most 135 bytes are
// kept, cut before a UTF-8 character) and a number that goes with it (an error count, an error
// code).  RT-safe: no allocation, no lock, no blocking call.  Raising an alarm that is active
// already does nothing, so a module may raise it every period.  Returns true when it was
// recorded; false when it was active already, or over the rate limit (counted; its state still
// changes), or the id is not 1 .. 1023 (counted).  An id the module did not declare is recorded
// and flagged as undeclared.  Works in run(), condition(), initialize() and start() of a thread
// module and anywhere in a process module; elsewhere (a thread the module started itself, stop())
// it does nothing and returns false.
bool raiseAlarm(uint32_t id, const char *detail = nullptr, double value = 0,
                Severity severity = Severity::Declared) noexcept;

// Clears alarm `id` of the calling module: its condition is gone.  RT-safe; clearing an alarm
// that is not active does nothing.  Returns true when it was recorded.
bool clearAlarm(uint32_t id) noexcept;

// Level style, for PLC-like code: raises `id` while `active`, clears it when not.  Call it every
// period with the condition; only the changes are recorded.
inline bool alarm(uint32_t id, bool active, const char *detail = nullptr, double value = 0) noexcept {
    return active ? raiseAlarm(id, detail, value) : clearAlarm(id);
}

// Declares alarm `id`'s text and severity, as module.xml's <alarm> does, from a thread module's
// initialize() or start() (not from run(): it allocates).  Severity::Declared stands for Medium.
// Declaring the same id again with the same text and severity is fine.  Throws
// irp::PropertyError for an id outside 1 .. 1023, an empty text, one over 200 characters or with
// a control character, an id declared already (in module.xml or by the module) otherwise, or a
// call outside initialize()/start() -- process modules declare in module.xml only.
void declareAlarm(uint32_t id, Severity severity, const char *text);

namespace detail {

// A hook taking Args... and returning void, bool or an integer, stored type-erased.
template <class... Args>
struct Hook {
    using Erased = void (*)();
    Erased fn = nullptr;
    int (*call)(Erased, Args...) = nullptr;  // 0 = success, as in the C table

    template <class R, class... A>
    Hook &operator=(R (*f)(A...)) {
        static_assert(sizeof...(A) == 0 || std::is_same_v<std::tuple<A...>, std::tuple<Args...>>,
                      "INDUROP_MODULE: this hook takes no arguments or the documented ones");
        static_assert(std::is_void_v<R> || std::is_same_v<R, bool> || std::is_integral_v<R>,
                      "INDUROP_MODULE: a hook returns void, bool or an integer");
        fn = reinterpret_cast<Erased>(f);
        call = [](Erased g, Args... args) -> int {
            auto h = reinterpret_cast<R (*)(A...)>(g);
            if constexpr (std::is_void_v<R>) {
                if constexpr (sizeof...(A) == 0)
                    h();
                else
                    h(args...);
                return 0;
            } else if constexpr (std::is_same_v<R, bool>) {
                bool ok;
                if constexpr (sizeof...(A) == 0)
                    ok = h();
                else
                    ok = h(args...);
                return ok ? 0 : 1;
            } else {
                R rc;
                if constexpr (sizeof...(A) == 0)
                    rc = h();
                else
                    rc = h(args...);
                return rc == 0 ? 0 : 1;
            }
        };
        return *this;
    }
    Hook &operator=(std::nullptr_t) {
        fn = nullptr;
        call = nullptr;
        return *this;
    }
    explicit operator bool() const { return fn != nullptr; }
};

struct ModuleFields {
    const char *name = nullptr;
    const char *description = nullptr;
    const char *author = nullptr;
    const char *license = nullptr;
    Hook<Property const &> initialize;
    Hook<> start;
    void (*run)() = nullptr;
    void (*stop)() = nullptr;
    Hook<> condition_hook;
};

inline void copyReason(char *err, size_t len, const char *what) {
    if (len == 0) return;
    std::snprintf(err, len, "%s", what ? what : "unknown error");
}

template <ModuleFields *F>
int initializeThunk(const indurop_property_list *list, char *err, size_t len) {
    try {
        if (F->initialize.call(F->initialize.fn, Property(list)) != 0) {
            copyReason(err, len, "initialize() reported failure");
            return 1;
        }
        return 0;
    } catch (const std::exception &e) {
        copyReason(err, len, e.what());
    } catch (...) {
        copyReason(err, len, "initialize() threw a non-standard exception");
    }
    return 1;
}

template <ModuleFields *F>
int startThunk(char *err, size_t len) {
    try {
        if (F->start.call(F->start.fn) != 0) {
            copyReason(err, len, "start() reported failure");
            return 1;
        }
        return 0;
    } catch (const std::exception &e) {
        copyReason(err, len, e.what());
    } catch (...) {
        copyReason(err, len, "start() threw a non-standard exception");
    }
    return 1;
}

template <ModuleFields *F>
int conditionThunk() {
    return F->condition_hook.call(F->condition_hook.fn) == 0 ? 1 : 0;
}

// condition returns "event occurred" (non-zero = true), the opposite sense of the 0-is-success
// hooks, so it is adapted here: Hook::call returns 0 for true/non-zero results.
struct ConditionField {
    Hook<> *hook;
    template <class R>
    ConditionField &operator=(R (*f)()) {
        static_assert(std::is_same_v<R, bool> || std::is_integral_v<R>, "condition returns int or bool");
        hook->fn = reinterpret_cast<Hook<>::Erased>(f);
        hook->call = [](Hook<>::Erased g) -> int { return reinterpret_cast<R (*)()>(g)() ? 0 : 1; };
        return *this;
    }
};

template <ModuleFields *F, class Setter>
indurop_module_v1 buildTable(Setter setter) {
    setter(*F);
    indurop_module_v1 t{};
    t.abi_version = INDUROP_MODULE_ABI_VERSION;
    t.struct_size = sizeof(indurop_module_v1);
    t.name = F->name;
    t.description = F->description;
    t.author = F->author;
    t.license = F->license;
    t.initialize = F->initialize ? &initializeThunk<F> : nullptr;
    t.start = F->start ? &startThunk<F> : nullptr;
    t.run = F->run;
    t.stop = F->stop;
    t.condition = F->condition_hook ? &conditionThunk<F> : nullptr;
    return t;
}

}  // namespace detail
}  // namespace irp

#ifndef INDUROP_NO_PLAIN_ENTRY_POINTS
extern "C" {
void initialize(irp::Property const &property);
void start(void);
void run(void);
void stop(void);
int condition(void);
}
#endif

// INDUROP_MODULE(field = value, ...): fills the module's descriptor table (see the top of this file).
#define INDUROP_MODULE(...)                                                                                            \
    namespace {                                                                                                        \
    ::irp::detail::ModuleFields indurop_module_fields_;                                                                \
    }                                                                                                                  \
    extern "C" __attribute__((visibility("default"))) const indurop_module_v1 *indurop_module_v1_descriptor(void) {    \
        static const indurop_module_v1 table =                                                                         \
            ::irp::detail::buildTable<&indurop_module_fields_>([](::irp::detail::ModuleFields &f) {                    \
                auto &name = f.name;                                                                                   \
                auto &description = f.description;                                                                     \
                auto &author = f.author;                                                                               \
                auto &license = f.license;                                                                             \
                auto &initialize = f.initialize;                                                                       \
                auto &start = f.start;                                                                                 \
                auto &run = f.run;                                                                                     \
                auto &stop = f.stop;                                                                                   \
                ::irp::detail::ConditionField condition{&f.condition_hook};                                            \
                (void)name, (void)description, (void)author, (void)license, (void)initialize;                          \
                (void)start, (void)run, (void)stop, (void)condition;                                                   \
                __VA_ARGS__;                                                                                           \
            });                                                                                                        \
        return &table;                                                                                                 \
    }

#include <indurop/process.h>
