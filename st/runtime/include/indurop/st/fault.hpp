// fault.hpp -- runtime faults of ST code: the place in the ST source, irp::st::RuntimeFault, the one
// function that throws it, and the checks the generated code calls (array index, subrange).
//
// A fault is thrown out of the module's run(); irpd catches it, disables the module and logs a
// `fault` event carrying what() (docs/faults.md), e.g. "main.st:12:9: division by zero (PROGRAM Main)".
// The throw allocates (the exception object and its text): it happens once, when the module stops.
#pragma once

#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

namespace irp::st {

// Where in the ST source a check stands.  The generated code makes one constexpr Place per site:
//   static constexpr irp::st::Place kAt12_9{"main.st", 12, 9, "PROGRAM Main"};
struct Place {
    const char *file;  // the ST file as the user names it ("main.st")
    int line;          // 1-based
    int column;        // 1-based
    const char *pou;   // "PROGRAM Main", "FUNCTION_BLOCK Axis", "FUNCTION Scale"
};

// What the generated code throws; what() is "<file>:<line>:<column>: <what> (<pou>)".
class RuntimeFault : public std::runtime_error {
public:
    RuntimeFault(const Place &place, const char *text) : std::runtime_error(format(place, text)), place_(place) {}
    const Place &place() const noexcept { return place_; }

private:
    static std::string format(const Place &p, const char *text) {
        char line[512];
        std::snprintf(line, sizeof line, "%s:%d:%d: %s (%s)", p.file ? p.file : "?", p.line, p.column,
                      text ? text : "runtime fault", p.pou ? p.pou : "?");
        return line;
    }
    Place place_;
};

// Throws RuntimeFault(place, what): the one way ST code faults.
[[noreturn, gnu::cold, gnu::noinline]] inline void fault(const Place &place, const char *what) {
    throw RuntimeFault(place, what);
}

// The same with a printf-style text (formatted on the stack; at most 255 characters are kept).
[[noreturn, gnu::cold, gnu::noinline]] __attribute__((format(printf, 2, 3))) inline void
faultf(const Place &place, const char *format, ...) {
    char text[256];
    va_list args;
    va_start(args, format);
    std::vsnprintf(text, sizeof text, format, args);
    va_end(args);
    fault(place, text);
}

namespace detail {
// "%lld" / "%llu" of an integer, for the fault texts below.
template <class I>
[[noreturn, gnu::cold]] void faultOutside(const Place &place, const char *what, I v, int64_t lo, int64_t hi) {
    char value[24];
    if constexpr (std::is_signed_v<I>)
        std::snprintf(value, sizeof value, "%lld", static_cast<long long>(v));
    else
        std::snprintf(value, sizeof value, "%llu", static_cast<unsigned long long>(v));
    faultf(place, what, value, static_cast<long long>(lo), static_cast<long long>(hi));
}
}  // namespace detail

// ARRAY[lo..hi]: the zero-based position of index i (any integer type), or a fault naming the
// index and the range.
template <class I>
constexpr std::size_t index(const Place &place, I i, int64_t lo, int64_t hi) {
    if (std::cmp_less(i, lo) || std::cmp_greater(i, hi)) [[unlikely]]
        detail::faultOutside(place, "index %s is outside the array's range %lld..%lld", i, lo, hi);
    return static_cast<std::size_t>(static_cast<int64_t>(i) - lo);
}

// A subrange type (lo..hi) of an integer type: v itself, or a fault naming the value and the subrange.
template <class T>
constexpr T range(const Place &place, T v, int64_t lo, int64_t hi) {
    if (std::cmp_less(v, lo) || std::cmp_greater(v, hi)) [[unlikely]]
        detail::faultOutside(place, "value %s is outside the subrange %lld..%lld", v, lo, hi);
    return v;
}

}  // namespace irp::st
