// types.hpp -- the IEC 61131-3 elementary types as C++ types (docs/st-runtime.md, PLAN29.md's table),
// and the concepts the rest of the ST runtime is written with.
#pragma once

#include <concepts>
#include <cstdint>
#include <type_traits>

namespace irp::st {

using BOOL = bool;
using SINT = int8_t;
using INT = int16_t;
using DINT = int32_t;
using LINT = int64_t;
using USINT = uint8_t;
using UINT = uint16_t;
using UDINT = uint32_t;
using ULINT = uint64_t;
// Bit strings: the same C++ types as the unsigned integers; the compiler allows them no arithmetic.
using BYTE = uint8_t;
using WORD = uint16_t;
using DWORD = uint32_t;
using LWORD = uint64_t;
using REAL = float;
using LREAL = double;
// Durations in nanoseconds; DATE and DATE_AND_TIME in nanoseconds since 1970-01-01 00:00 UTC,
// TIME_OF_DAY in nanoseconds since midnight.  The same C++ type as LINT: the compiler keeps them
// apart, the runtime's functions for them have names of their own (time.hpp, convert.hpp).
using TIME = int64_t;
using LTIME = int64_t;
using DATE = int64_t;
using TOD = int64_t;
using TIME_OF_DAY = int64_t;
using DT = int64_t;
using DATE_AND_TIME = int64_t;
// The 3rd edition's long forms: the same nanoseconds (their integer conversions are in ns).
using LDATE = int64_t;
using LTOD = int64_t;
using LDT = int64_t;
// An enumeration's values (PLAN29.md).
using ENUM = int16_t;

// Nanoseconds in the units the time types are written in.
inline constexpr int64_t kNsPerUs = 1'000;
inline constexpr int64_t kNsPerMs = 1'000'000;
inline constexpr int64_t kNsPerSecond = 1'000'000'000;
inline constexpr int64_t kNsPerMinute = 60 * kNsPerSecond;
inline constexpr int64_t kNsPerHour = 60 * kNsPerMinute;
inline constexpr int64_t kNsPerDay = 24 * kNsPerHour;

// An IEC integer (ANY_INT or ANY_BIT but BOOL).
template <class T>
concept Integer = std::integral<T> && !std::same_as<T, bool>;
// ANY_REAL.
template <class T>
concept Real = std::floating_point<T>;
// ANY_NUM (and the bit strings, which share the unsigned types).
template <class T>
concept Number = Integer<T> || Real<T>;

namespace detail {
// The unsigned type in which T's arithmetic wraps without promotion to int (uint8_t * uint8_t is
// an int multiplication in C++, which can overflow: computed in unsigned int instead).
template <Integer T>
using WrapType = std::conditional_t<(sizeof(T) < sizeof(unsigned)), unsigned, std::make_unsigned_t<T>>;
}  // namespace detail

}  // namespace irp::st
