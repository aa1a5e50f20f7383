// convert.hpp -- the type conversions `<FROM>_TO_<TO>` of the elementary types (not STRING: see
// string_convert.hpp), and TRUNC.  One table (convertible(), convert()) decides what exists and
// what it does; the names are generated from it.  docs/st-runtime.md gives the reasons:
//   - integer to integer (and the bit strings): the target's bits (two's complement wrap, as CODESYS);
//   - REAL/LREAL to an integer: to the nearest integer, ties to even (IEC 60559's rounding:
//     2.5 -> 2, 3.5 -> 4, -2.5 -> -2); out of the target's range it saturates to its minimum or
//     maximum, NaN gives 0;  TRUNC: toward zero, with the same saturation;
//   - to BOOL: value <> 0; from BOOL: 0 or 1;
//   - TIME in milliseconds, LTIME in nanoseconds (TIME_TO_DINT(T#1s) = 1000; LTIME_TO_LINT(LTIME#1s)
//     = 1000000000); to TIME from REAL: milliseconds, kept to the nanosecond;
//   - DATE and DT in seconds since 1970-01-01, TOD in milliseconds since midnight (CODESYS); LDATE,
//     LTOD, LDT in nanoseconds;
//   - between the time types: TIME <-> LTIME; a date and time (DT, LDT) to any date, time of day or
//     date and time; a date (DATE, LDATE) to a date or a date and time; TOD <-> LTOD; no others.
// The compiler spells TIME_OF_DAY and DATE_AND_TIME as TOD and DT in these names.
#pragma once

#include <indurop/st/types.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

namespace irp::st {

enum class Iec : uint8_t {
    BOOL,
    SINT,
    INT,
    DINT,
    LINT,
    USINT,
    UINT,
    UDINT,
    ULINT,
    BYTE,
    WORD,
    DWORD,
    LWORD,
    REAL,
    LREAL,
    TIME,
    LTIME,
    DATE,
    TOD,
    DT,
    LDATE,
    LTOD,
    LDT,
};

// What each elementary type is made of: its C++ type, its kind and, for the time types, the
// nanoseconds in one unit of its integer conversions.
enum class Kind : uint8_t { Bool, Integer, Real, Duration, Date };

template <Iec K>
struct Info;
#define IRP_ST_INFO(NAME, KIND, UNIT_NS)                                                                               \
    template <>                                                                                                        \
    struct Info<Iec::NAME> {                                                                                           \
        using type = NAME;                                                                                             \
        static constexpr Kind kind = Kind::KIND;                                                                       \
        static constexpr int64_t unit_ns = UNIT_NS;                                                                    \
    };
IRP_ST_INFO(BOOL, Bool, 0)
IRP_ST_INFO(SINT, Integer, 0)
IRP_ST_INFO(INT, Integer, 0)
IRP_ST_INFO(DINT, Integer, 0)
IRP_ST_INFO(LINT, Integer, 0)
IRP_ST_INFO(USINT, Integer, 0)
IRP_ST_INFO(UINT, Integer, 0)
IRP_ST_INFO(UDINT, Integer, 0)
IRP_ST_INFO(ULINT, Integer, 0)
IRP_ST_INFO(BYTE, Integer, 0)
IRP_ST_INFO(WORD, Integer, 0)
IRP_ST_INFO(DWORD, Integer, 0)
IRP_ST_INFO(LWORD, Integer, 0)
IRP_ST_INFO(REAL, Real, 0)
IRP_ST_INFO(LREAL, Real, 0)
IRP_ST_INFO(TIME, Duration, kNsPerMs)
IRP_ST_INFO(LTIME, Duration, 1)
IRP_ST_INFO(DATE, Date, kNsPerSecond)
IRP_ST_INFO(TOD, Date, kNsPerMs)
IRP_ST_INFO(DT, Date, kNsPerSecond)
IRP_ST_INFO(LDATE, Date, 1)
IRP_ST_INFO(LTOD, Date, 1)
IRP_ST_INFO(LDT, Date, 1)
#undef IRP_ST_INFO

constexpr bool isDate(Iec k) { return k == Iec::DATE || k == Iec::LDATE; }
constexpr bool isTimeOfDay(Iec k) { return k == Iec::TOD || k == Iec::LTOD; }
constexpr bool isDateAndTime(Iec k) { return k == Iec::DT || k == Iec::LDT; }

// Whether FROM_TO_TO exists.
constexpr bool convertible(Iec to, Iec from) {
    auto kind = [](Iec k) {
        switch (k) {
        case Iec::BOOL: return Kind::Bool;
        case Iec::REAL:
        case Iec::LREAL: return Kind::Real;
        case Iec::TIME:
        case Iec::LTIME: return Kind::Duration;
        case Iec::DATE:
        case Iec::TOD:
        case Iec::DT:
        case Iec::LDATE:
        case Iec::LTOD:
        case Iec::LDT: return Kind::Date;
        default: return Kind::Integer;
        }
    };
    auto plain = [](Kind k) { return k == Kind::Bool || k == Kind::Integer || k == Kind::Real; };
    if (plain(kind(to)) || plain(kind(from))) return true;  // number or bits on at least one side
    if (to == from) return true;
    if (kind(to) == Kind::Duration && kind(from) == Kind::Duration) return true;  // TIME <-> LTIME
    if (kind(to) != Kind::Date || kind(from) != Kind::Date) return false;
    if (isDateAndTime(from)) return true;
    if (isDate(from)) return isDate(to) || isDateAndTime(to);
    return isTimeOfDay(to);  // TOD <-> LTOD
}

// REAL/LREAL to an integer type: nearest, ties to even; saturated; NaN -> 0.  Independent of the
// FPU's rounding mode.
template <Integer T>
inline T roundToInteger(double x) noexcept {
    if (std::isnan(x)) return 0;
    double r = std::floor(x);
    const double frac = x - r;
    if (frac > 0.5 || (frac == 0.5 && std::fmod(r, 2.0) != 0.0)) r += 1.0;
    if (r <= static_cast<double>(std::numeric_limits<T>::min())) return std::numeric_limits<T>::min();
    if (r >= static_cast<double>(std::numeric_limits<T>::max())) return std::numeric_limits<T>::max();
    return static_cast<T>(r);
}

// TRUNC: toward zero; saturated; NaN -> 0.  TRUNC(x) gives a DINT (IEC 61131-3 2nd edition and
// CODESYS); TRUNC_<INT type>(x) the named type.
template <Integer T>
inline T truncToInteger(double x) noexcept {
    if (std::isnan(x)) return 0;
    const double r = std::trunc(x);
    if (r <= static_cast<double>(std::numeric_limits<T>::min())) return std::numeric_limits<T>::min();
    if (r >= static_cast<double>(std::numeric_limits<T>::max())) return std::numeric_limits<T>::max();
    return static_cast<T>(r);
}
template <Real R>
inline DINT TRUNC(R x) noexcept {
    return truncToInteger<DINT>(x);
}
#define IRP_ST_TRUNC(NAME)                                                                                             \
    template <Real R>                                                                                                  \
    inline NAME TRUNC_##NAME(R x) noexcept {                                                                           \
        return truncToInteger<NAME>(x);                                                                                \
    }
IRP_ST_TRUNC(SINT)
IRP_ST_TRUNC(INT)
IRP_ST_TRUNC(DINT)
IRP_ST_TRUNC(LINT)
IRP_ST_TRUNC(USINT)
IRP_ST_TRUNC(UINT)
IRP_ST_TRUNC(UDINT)
IRP_ST_TRUNC(ULINT)
#undef IRP_ST_TRUNC
// The 3rd edition's spelling: REAL_TRUNC_INT(x), LREAL_TRUNC_DINT(x), ...
#define IRP_ST_TRUNC_FROM(REALTYPE, NAME)                                                                              \
    inline NAME REALTYPE##_TRUNC_##NAME(REALTYPE x) noexcept { return truncToInteger<NAME>(x); }
#define IRP_ST_TRUNC_ALL(NAME) IRP_ST_TRUNC_FROM(REAL, NAME) IRP_ST_TRUNC_FROM(LREAL, NAME)
IRP_ST_TRUNC_ALL(SINT)
IRP_ST_TRUNC_ALL(INT)
IRP_ST_TRUNC_ALL(DINT)
IRP_ST_TRUNC_ALL(LINT)
IRP_ST_TRUNC_ALL(USINT)
IRP_ST_TRUNC_ALL(UINT)
IRP_ST_TRUNC_ALL(UDINT)
IRP_ST_TRUNC_ALL(ULINT)
#undef IRP_ST_TRUNC_ALL
#undef IRP_ST_TRUNC_FROM

// The conversion itself; convertible(To, From) must hold.
template <Iec To, Iec From>
inline typename Info<To>::type convert(typename Info<From>::type v) noexcept {
    using T = typename Info<To>::type;
    using F = typename Info<From>::type;
    constexpr Kind to = Info<To>::kind, from = Info<From>::kind;
    static_assert(convertible(To, From), "no such IEC conversion");
    if constexpr (to == Kind::Bool) {
        return v != 0;
    } else if constexpr (from == Kind::Bool) {
        return convert<To, Iec::SINT>(v ? 1 : 0);
    } else if constexpr (from == Kind::Duration || from == Kind::Date) {
        if constexpr (to == Kind::Duration || to == Kind::Date) {
            if constexpr (isDateAndTime(From) && isDate(To)) return v - ((v % kNsPerDay) + kNsPerDay) % kNsPerDay;
            if constexpr (isDateAndTime(From) && isTimeOfDay(To)) return ((v % kNsPerDay) + kNsPerDay) % kNsPerDay;
            return v;  // TIME <-> LTIME, DATE -> DT, DT <-> LDT, ...: the same nanoseconds
        } else if constexpr (to == Kind::Real) {
            return static_cast<T>(static_cast<double>(v) / static_cast<double>(Info<From>::unit_ns));
        } else {
            return static_cast<T>(v / Info<From>::unit_ns);  // toward zero, then the target's bits
        }
    } else if constexpr (to == Kind::Duration || to == Kind::Date) {
        if constexpr (from == Kind::Real)
            return roundToInteger<int64_t>(static_cast<double>(v) * static_cast<double>(Info<To>::unit_ns));
        else  // wraps as int64 (ULINT above its range too)
            return static_cast<int64_t>(static_cast<uint64_t>(v) * static_cast<uint64_t>(Info<To>::unit_ns));
    } else if constexpr (to == Kind::Integer && from == Kind::Real) {
        return roundToInteger<T>(static_cast<double>(v));
    } else {
        static_cast<void>(sizeof(F));
        return static_cast<T>(v);  // integer -> integer: the target's bits; -> REAL: nearest
    }
}

// The named conversions: BOOL_TO_INT, REAL_TO_INT, TIME_TO_DINT, DT_TO_TOD, ...  (529 names, of
// which those convertible() refuses do not resolve.)
#define IRP_ST_ELEMENTARY_TO(X, FROM)                                                                                  \
    X(FROM, BOOL)                                                                                                      \
    X(FROM, SINT)                                                                                                      \
    X(FROM, INT)                                                                                                       \
    X(FROM, DINT)                                                                                                      \
    X(FROM, LINT)                                                                                                      \
    X(FROM, USINT)                                                                                                     \
    X(FROM, UINT)                                                                                                      \
    X(FROM, UDINT)                                                                                                     \
    X(FROM, ULINT)                                                                                                     \
    X(FROM, BYTE)                                                                                                      \
    X(FROM, WORD)                                                                                                      \
    X(FROM, DWORD)                                                                                                     \
    X(FROM, LWORD)                                                                                                     \
    X(FROM, REAL)                                                                                                      \
    X(FROM, LREAL)                                                                                                     \
    X(FROM, TIME)                                                                                                      \
    X(FROM, LTIME)                                                                                                     \
    X(FROM, DATE)                                                                                                      \
    X(FROM, TOD)                                                                                                       \
    X(FROM, DT)                                                                                                        \
    X(FROM, LDATE)                                                                                                     \
    X(FROM, LTOD)                                                                                                      \
    X(FROM, LDT)
#define IRP_ST_ELEMENTARY(X)                                                                                           \
    X(BOOL)                                                                                                            \
    X(SINT)                                                                                                            \
    X(INT)                                                                                                             \
    X(DINT)                                                                                                            \
    X(LINT)                                                                                                            \
    X(USINT)                                                                                                           \
    X(UINT)                                                                                                            \
    X(UDINT)                                                                                                           \
    X(ULINT)                                                                                                           \
    X(BYTE)                                                                                                            \
    X(WORD)                                                                                                            \
    X(DWORD)                                                                                                           \
    X(LWORD)                                                                                                           \
    X(REAL)                                                                                                            \
    X(LREAL)                                                                                                           \
    X(TIME)                                                                                                            \
    X(LTIME)                                                                                                           \
    X(DATE)                                                                                                            \
    X(TOD)                                                                                                             \
    X(DT)                                                                                                              \
    X(LDATE)                                                                                                           \
    X(LTOD)                                                                                                            \
    X(LDT)
#define IRP_ST_CONVERSION(FROM, TO)                                                                                    \
    template <int = 0>                                                                                                 \
    requires(convertible(Iec::TO, Iec::FROM)) inline TO FROM##_TO_##TO(FROM v) noexcept {                              \
        return convert<Iec::TO, Iec::FROM>(v);                                                                         \
    }
#define IRP_ST_CONVERSIONS_FROM(FROM) IRP_ST_ELEMENTARY_TO(IRP_ST_CONVERSION, FROM)
IRP_ST_ELEMENTARY(IRP_ST_CONVERSIONS_FROM)
#undef IRP_ST_CONVERSIONS_FROM
#undef IRP_ST_CONVERSION

}  // namespace irp::st
