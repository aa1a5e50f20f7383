// select.hpp -- selection: SEL, MAX, MIN, LIMIT, MUX, and MOVE (IEC 61131-3 tables 27 and 28).
// They work on any type with < (numbers, bit strings, time types, String<N>); all arguments have
// one type (the compiler converts them first), except MUX's selector.
#pragma once

#include <indurop/st/fault.hpp>
#include <indurop/st/types.hpp>

#include <type_traits>
#include <utility>

namespace irp::st {

// SEL(G, IN0, IN1): IN0 when G is FALSE, IN1 when TRUE.
template <class T>
constexpr T SEL(bool g, const T &in0, const std::type_identity_t<T> &in1) {
    return g ? in1 : in0;
}

// MAX / MIN of two or more values; the first of equal ones.
template <class T, class... More>
constexpr T MAX(const T &a, const std::type_identity_t<T> &b, const More &...more) {
    T r = a < b ? b : a;
    ((r = r < static_cast<T>(more) ? static_cast<T>(more) : r), ...);
    return r;
}
template <class T, class... More>
constexpr T MIN(const T &a, const std::type_identity_t<T> &b, const More &...more) {
    T r = b < a ? b : a;
    ((r = static_cast<T>(more) < r ? static_cast<T>(more) : r), ...);
    return r;
}

// LIMIT(MN, IN, MX) = MIN(MAX(IN, MN), MX), as the standard defines it: with MN > MX the result
// is MX (no fault).
template <class T>
constexpr T LIMIT(const T &mn, const std::type_identity_t<T> &in, const std::type_identity_t<T> &mx) {
    return MIN(MAX(in, mn), mx);
}

// MUX(K, IN0, IN1, ...): IN<K>; K outside 0 .. count-1 faults, naming K and the range.
template <Integer K, class T, class... More>
constexpr T MUX(const Place &place, K k, const T &in0, const More &...more) {
    static_assert((std::is_same_v<T, More> && ...), "MUX: the inputs have one type");
    constexpr std::size_t count = 1 + sizeof...(More);
    if (std::cmp_less(k, 0) || std::cmp_greater_equal(k, count)) [[unlikely]]
        detail::faultOutside(place, "MUX selector %s is outside %lld..%lld", k, 0, static_cast<int64_t>(count - 1));
    const T *inputs[count] = {&in0, &more...};
    return *inputs[static_cast<std::size_t>(k)];
}

// MOVE(IN): IN (the assignment as a function).
template <class T>
constexpr T MOVE(const T &in) {
    return in;
}

}  // namespace irp::st
