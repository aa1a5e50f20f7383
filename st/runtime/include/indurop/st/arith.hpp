// arith.hpp -- IEC arithmetic and comparison: integers wrap as their type (two's complement, no C++
// undefined behaviour), DIV and MOD fault on a zero divisor, REAL and LREAL are IEEE 754.
//
// The generated code calls these for every integer +, -, *, /, MOD and unary minus (REAL and
// LREAL may use the C++ operators: the functions below are the same for them).  Both operands
// have one type: the compiler converts them first (IEC's implicit widening); a literal operand
// converts to the other's type.
#pragma once

#include <indurop/st/fault.hpp>
#include <indurop/st/types.hpp>

#include <limits>
#include <type_traits>
#include <utility>

namespace irp::st {

template <Number T>
constexpr T ADD(T a, std::type_identity_t<T> b) noexcept {
    if constexpr (Real<T>) {
        return a + b;
    } else {
        using U = detail::WrapType<T>;
        return static_cast<T>(static_cast<U>(a) + static_cast<U>(b));
    }
}

// ADD(a, b, c, ...) as the standard's extensible ADD.
template <Number T, class... More>
constexpr T ADD(T a, std::type_identity_t<T> b, std::type_identity_t<T> c, More... more) noexcept {
    return ADD(ADD(a, b), c, static_cast<T>(more)...);
}

template <Number T>
constexpr T SUB(T a, std::type_identity_t<T> b) noexcept {
    if constexpr (Real<T>) {
        return a - b;
    } else {
        using U = detail::WrapType<T>;
        return static_cast<T>(static_cast<U>(a) - static_cast<U>(b));
    }
}

template <Number T>
constexpr T MUL(T a, std::type_identity_t<T> b) noexcept {
    if constexpr (Real<T>) {
        return a * b;
    } else {
        using U = detail::WrapType<T>;
        return static_cast<T>(static_cast<U>(a) * static_cast<U>(b));
    }
}

template <Number T, class... More>
constexpr T MUL(T a, std::type_identity_t<T> b, std::type_identity_t<T> c, More... more) noexcept {
    return MUL(MUL(a, b), c, static_cast<T>(more)...);
}

// Unary minus: NEG(INT#-32768) = -32768 (wraps).
template <Number T>
constexpr T NEG(T a) noexcept {
    if constexpr (Real<T>) {
        return -a;
    } else {
        using U = detail::WrapType<T>;
        return static_cast<T>(U{0} - static_cast<U>(a));
    }
}

// Integer division truncates toward zero (as C++ and IEC); a zero divisor faults; the one overflow,
// the type's minimum divided by -1, wraps to the minimum.  REAL: IEEE (x / 0.0 is an infinity).
template <Number T>
constexpr T DIV(const Place &place, T a, std::type_identity_t<T> b) {
    if constexpr (Real<T>) {
        return a / b;
    } else {
        if (b == 0) [[unlikely]]
            fault(place, "division by zero");
        if constexpr (std::is_signed_v<T>)
            if (b == -1) return NEG(a);
        return static_cast<T>(a / b);
    }
}

// The remainder of DIV: the sign of the dividend (MOD(-7, 2) = -1); a zero divisor faults.
template <Integer T>
constexpr T MOD(const Place &place, T a, std::type_identity_t<T> b) {
    if (b == 0) [[unlikely]]
        fault(place, "division by zero (MOD)");
    if constexpr (std::is_signed_v<T>)
        if (b == -1) return 0;
    return static_cast<T>(a % b);
}

// ---- comparison (extensible: GT(a, b, c) is a > b AND b > c) ------------------------------------
// Integers of different signedness compare by value (std::cmp_*), never by C++'s conversions.
namespace detail {
template <class A, class B>
constexpr bool eq(const A &a, const B &b) noexcept {
    if constexpr (Integer<A> && Integer<B>)
        return std::cmp_equal(a, b);
    else
        return a == b;
}
template <class A, class B>
constexpr bool lt(const A &a, const B &b) noexcept {
    if constexpr (Integer<A> && Integer<B>)
        return std::cmp_less(a, b);
    else
        return a < b;
}
}  // namespace detail

template <class A, class B>
constexpr bool EQ(const A &a, const B &b) noexcept {
    return detail::eq(a, b);
}
template <class A, class B, class C, class... More>
constexpr bool EQ(const A &a, const B &b, const C &c, const More &...more) noexcept {
    return detail::eq(a, b) && EQ(b, c, more...);
}
template <class A, class B>
constexpr bool NE(const A &a, const B &b) noexcept {
    return !detail::eq(a, b);
}
template <class A, class B>
constexpr bool LT(const A &a, const B &b) noexcept {
    return detail::lt(a, b);
}
template <class A, class B, class C, class... More>
constexpr bool LT(const A &a, const B &b, const C &c, const More &...more) noexcept {
    return detail::lt(a, b) && LT(b, c, more...);
}
template <class A, class B>
constexpr bool GT(const A &a, const B &b) noexcept {
    return detail::lt(b, a);
}
template <class A, class B, class C, class... More>
constexpr bool GT(const A &a, const B &b, const C &c, const More &...more) noexcept {
    return detail::lt(b, a) && GT(b, c, more...);
}
template <class A, class B>
constexpr bool LE(const A &a, const B &b) noexcept {
    return !detail::lt(b, a);
}
template <class A, class B, class C, class... More>
constexpr bool LE(const A &a, const B &b, const C &c, const More &...more) noexcept {
    return !detail::lt(b, a) && LE(b, c, more...);
}
template <class A, class B>
constexpr bool GE(const A &a, const B &b) noexcept {
    return !detail::lt(a, b);
}
template <class A, class B, class C, class... More>
constexpr bool GE(const A &a, const B &b, const C &c, const More &...more) noexcept {
    return !detail::lt(a, b) && GE(b, c, more...);
}

}  // namespace irp::st
