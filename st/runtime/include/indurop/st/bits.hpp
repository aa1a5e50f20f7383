// bits.hpp -- bit strings: AND, OR, XOR, NOT (also on BOOL), SHL, SHR, ROL, ROR per width, and
// bit access `x.3` (getBit / setBit).
#pragma once

#include <indurop/st/types.hpp>

#include <bit>
#include <climits>
#include <type_traits>
#include <utility>

namespace irp::st {

template <class T>
concept BitString = std::same_as<T, bool> || Integer<T>;

template <BitString T, class... More>
constexpr T AND(T a, std::type_identity_t<T> b, More... more) noexcept {
    T r = static_cast<T>(a & b);
    ((r = static_cast<T>(r & static_cast<T>(more))), ...);
    return r;
}
template <BitString T, class... More>
constexpr T OR(T a, std::type_identity_t<T> b, More... more) noexcept {
    T r = static_cast<T>(a | b);
    ((r = static_cast<T>(r | static_cast<T>(more))), ...);
    return r;
}
template <BitString T, class... More>
constexpr T XOR(T a, std::type_identity_t<T> b, More... more) noexcept {
    T r = static_cast<T>(a ^ b);
    ((r = static_cast<T>(r ^ static_cast<T>(more))), ...);
    return r;
}
template <BitString T>
constexpr T NOT(T a) noexcept {
    if constexpr (std::is_same_v<T, bool>)
        return !a;
    else
        return static_cast<T>(~a);
}

// Shifts are logical on the type's bits, filling with zeros; a shift by the width or more (or by
// a negative count) gives 0.
template <Integer T, Integer N>
constexpr T SHL(T in, N n) noexcept {
    using U = std::make_unsigned_t<T>;
    constexpr int width = sizeof(T) * CHAR_BIT;
    if (std::cmp_less(n, 0) || std::cmp_greater_equal(n, width)) return 0;
    return static_cast<T>(static_cast<U>(static_cast<detail::WrapType<T>>(static_cast<U>(in)) << n));
}
template <Integer T, Integer N>
constexpr T SHR(T in, N n) noexcept {
    using U = std::make_unsigned_t<T>;
    constexpr int width = sizeof(T) * CHAR_BIT;
    if (std::cmp_less(n, 0) || std::cmp_greater_equal(n, width)) return 0;
    return static_cast<T>(static_cast<U>(static_cast<U>(in) >> n));
}
// Rotations are modulo the width: ROL(BYTE#16#81, 9) = ROL(BYTE#16#81, 1) = 16#03; a negative
// count rotates the other way.
template <Integer T, Integer N>
constexpr T ROL(T in, N n) noexcept {
    using U = std::make_unsigned_t<T>;
    constexpr int width = sizeof(T) * CHAR_BIT;
    return static_cast<T>(std::rotl(static_cast<U>(in), static_cast<int>(n % width)));
}
template <Integer T, Integer N>
constexpr T ROR(T in, N n) noexcept {
    using U = std::make_unsigned_t<T>;
    constexpr int width = sizeof(T) * CHAR_BIT;
    return static_cast<T>(std::rotr(static_cast<U>(in), static_cast<int>(n % width)));
}

// Bit access: `x.3` reads getBit<3>(x); `x.3 := v` is setBit<3>(x, v).  The bit number is a
// constant in ST, checked against the width here at compile time.
template <int Bit, Integer T>
constexpr bool getBit(T x) noexcept {
    static_assert(Bit >= 0 && Bit < int(sizeof(T) * CHAR_BIT), "bit access past the type's width");
    return (static_cast<std::make_unsigned_t<T>>(x) >> Bit) & 1u;
}
template <int Bit, Integer T>
constexpr void setBit(T &x, bool v) noexcept {
    static_assert(Bit >= 0 && Bit < int(sizeof(T) * CHAR_BIT), "bit access past the type's width");
    using U = std::make_unsigned_t<T>;
    const U mask = static_cast<U>(U{1} << Bit);
    x = static_cast<T>(v ? static_cast<U>(static_cast<U>(x) | mask) : static_cast<U>(static_cast<U>(x) & ~mask));
}

}  // namespace irp::st
