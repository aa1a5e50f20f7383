// string.hpp -- STRING[n]: irp::st::String<N>, a bounded NUL-terminated string whose memory is
// exactly char[N+1] (plain data: it lives in shared memory as it does in a local), and the
// standard's string functions LEN, LEFT, RIGHT, MID, CONCAT, INSERT, DELETE, REPLACE, FIND.
//
// Bounds (docs/st-runtime.md): nothing ever writes past N characters; an assignment or a result
// longer than its target is cut at the target's capacity.  Positions are 1-based (IEC); a length
// below 0 counts as 0, and a position outside the string is clamped, never a fault:
//   LEFT(s, L), RIGHT(s, L): at most LEN(s) characters;
//   MID(s, L, P): '' when P < 1 or P > LEN(s), else at most what follows P;
//   DELETE(s, L, P): s itself when P < 1 or P > LEN(s);
//   INSERT(s1, s2, P): s2 after the first P characters of s1 (P clamped to 0 .. LEN(s1));
//   REPLACE(s1, s2, L, P): DELETE then INSERT at P (P clamped to 1 .. LEN(s1) + 1);
//   FIND(s1, s2): the position of s2's first occurrence in s1, 0 when absent or s2 is empty.
// The results of CONCAT, INSERT and REPLACE have room for both inputs (String<N + M>); the other
// functions return their input's capacity.  Characters are bytes; the compiler resolves the
// $-escapes of literals.  Comparison is by byte values, as strcmp on unsigned characters.
#pragma once

#include <indurop/st/types.hpp>

#include <algorithm>
#include <compare>
#include <cstddef>
#include <cstring>
#include <string>
#include <type_traits>
#include <utility>

namespace irp::st {

// The IEC default length of STRING.
inline constexpr std::size_t kDefaultStringLength = 80;

template <std::size_t N = kDefaultStringLength>
struct String {
    static constexpr std::size_t capacity = N;
    char data[N + 1];  // NUL-terminated when shorter than N; data[N] is always NUL once written here

    constexpr String() noexcept : data{} {}
    // From a literal or any C string (cut at N).
    constexpr String(const char *s) noexcept : data{} { assign(s, std::char_traits<char>::length(s)); }
    template <std::size_t M>
    constexpr String(const String<M> &other) noexcept : data{} {
        assign(other.data, other.length());
    }
    constexpr String(const String &) noexcept = default;
    constexpr String &operator=(const String &) noexcept = default;
    template <std::size_t M>
    constexpr String &operator=(const String<M> &other) noexcept {
        assign(other.data, other.length());
        return *this;
    }
    constexpr String &operator=(const char *s) noexcept {
        assign(s, std::char_traits<char>::length(s));
        return *this;
    }

    // Its length: never more than N, even when the bytes came from outside unterminated.
    constexpr std::size_t length() const noexcept {
        std::size_t n = 0;
        while (n < N && data[n] != '\0') ++n;
        return n;
    }
    constexpr const char *c_str() const noexcept { return data; }  // NUL-terminated once written here

    // Sets the content to n bytes from s (cut at N).  s may point into this string.
    constexpr void assign(const char *s, std::size_t n) noexcept {
        n = std::min(n, N);
        std::char_traits<char>::move(data, s, n);
        for (std::size_t i = n; i <= N; ++i) data[i] = '\0';
    }
    // Appends n bytes from s, as far as they fit.
    constexpr void append(const char *s, std::size_t n) noexcept {
        const std::size_t at = length();
        n = std::min(n, N - at);
        std::char_traits<char>::move(data + at, s, n);
        data[at + n] = '\0';
    }
};

template <std::size_t K>
String(const char (&)[K]) -> String<K - 1>;

static_assert(sizeof(String<80>) == 81 && alignof(String<80>) == 1, "STRING[80] is char[81] in memory");
static_assert(std::is_trivially_copyable_v<String<80>> && std::is_standard_layout_v<String<80>>,
              "a String lives in shared memory: plain data");

namespace detail {
template <std::size_t N, std::size_t M>
constexpr int compare(const String<N> &a, const String<M> &b) noexcept {
    const std::size_t la = a.length(), lb = b.length();
    for (std::size_t i = 0; i < la && i < lb; ++i) {
        const auto x = static_cast<unsigned char>(a.data[i]), y = static_cast<unsigned char>(b.data[i]);
        if (x != y) return x < y ? -1 : 1;
    }
    return la == lb ? 0 : (la < lb ? -1 : 1);
}
// A count or position argument of any integer type, as a signed 64-bit value.
template <Integer I>
constexpr int64_t arg(I v) noexcept {
    return std::cmp_greater(v, INT64_MAX) ? INT64_MAX : static_cast<int64_t>(v);
}
constexpr std::size_t clamp(int64_t v, std::size_t lo, std::size_t hi) noexcept {
    return v < static_cast<int64_t>(lo) ? lo : (static_cast<uint64_t>(v) > hi ? hi : static_cast<std::size_t>(v));
}
}  // namespace detail

template <std::size_t N, std::size_t M>
constexpr bool operator==(const String<N> &a, const String<M> &b) noexcept {
    return detail::compare(a, b) == 0;
}
template <std::size_t N, std::size_t M>
constexpr std::strong_ordering operator<=>(const String<N> &a, const String<M> &b) noexcept {
    return detail::compare(a, b) <=> 0;
}

// With a literal: `s = 'abc'` compares as String("abc").  (The string functions take String<N>
// only: the generator writes a literal argument as irp::st::String("abc"), its capacity deduced.)
template <std::size_t N>
constexpr bool operator==(const String<N> &a, const char *b) noexcept {
    return detail::compare(a, String<N>(b)) == 0 && std::char_traits<char>::length(b) <= N;
}
template <std::size_t N>
constexpr std::strong_ordering operator<=>(const String<N> &a, const char *b) noexcept {
    const std::size_t n = std::char_traits<char>::length(b);
    const int c = detail::compare(a, String<N>(b));
    return c != 0 ? c <=> 0 : (n > N ? std::strong_ordering::less : std::strong_ordering::equal);
}

// LEN(s): an INT, as the standard's LEN.
template <std::size_t N>
constexpr INT LEN(const String<N> &s) noexcept {
    return static_cast<INT>(s.length());
}

template <std::size_t N, Integer I>
constexpr String<N> LEFT(const String<N> &s, I l) noexcept {
    String<N> r;
    r.assign(s.data, detail::clamp(detail::arg(l), 0, s.length()));
    return r;
}

template <std::size_t N, Integer I>
constexpr String<N> RIGHT(const String<N> &s, I l) noexcept {
    const std::size_t len = s.length(), n = detail::clamp(detail::arg(l), 0, len);
    String<N> r;
    r.assign(s.data + (len - n), n);
    return r;
}

template <std::size_t N, Integer I, Integer J>
constexpr String<N> MID(const String<N> &s, I l, J p) noexcept {
    const std::size_t len = s.length();
    const int64_t pos = detail::arg(p);
    String<N> r;
    if (pos < 1 || pos > static_cast<int64_t>(len)) return r;
    const std::size_t from = static_cast<std::size_t>(pos - 1);
    r.assign(s.data + from, detail::clamp(detail::arg(l), 0, len - from));
    return r;
}

template <std::size_t N, std::size_t M, std::size_t... More>
constexpr String<N + M + (0 + ... + More)> CONCAT(const String<N> &a, const String<M> &b,
                                                  const String<More> &...more) noexcept {
    String<N + M + (0 + ... + More)> r;
    r.assign(a.data, a.length());
    r.append(b.data, b.length());
    (r.append(more.data, more.length()), ...);
    return r;
}

template <std::size_t N, std::size_t M, Integer I>
constexpr String<N + M> INSERT(const String<N> &s1, const String<M> &s2, I p) noexcept {
    const std::size_t len = s1.length(), at = detail::clamp(detail::arg(p), 0, len);
    String<N + M> r;
    r.assign(s1.data, at);
    r.append(s2.data, s2.length());
    r.append(s1.data + at, len - at);
    return r;
}

template <std::size_t N, Integer I, Integer J>
constexpr String<N> DELETE(const String<N> &s, I l, J p) noexcept {
    const std::size_t len = s.length();
    const int64_t pos = detail::arg(p);
    if (pos < 1 || pos > static_cast<int64_t>(len)) return s;
    const std::size_t from = static_cast<std::size_t>(pos - 1), n = detail::clamp(detail::arg(l), 0, len - from);
    String<N> r;
    r.assign(s.data, from);
    r.append(s.data + from + n, len - from - n);
    return r;
}

template <std::size_t N, std::size_t M, Integer I, Integer J>
constexpr String<N + M> REPLACE(const String<N> &s1, const String<M> &s2, I l, J p) noexcept {
    const std::size_t len = s1.length(), from = detail::clamp(detail::arg(p), 1, len + 1) - 1;
    const std::size_t n = detail::clamp(detail::arg(l), 0, len - from);
    String<N + M> r;
    r.assign(s1.data, from);
    r.append(s2.data, s2.length());
    r.append(s1.data + from + n, len - from - n);
    return r;
}

template <std::size_t N, std::size_t M>
constexpr INT FIND(const String<N> &s1, const String<M> &s2) noexcept {
    const std::size_t len = s1.length(), n = s2.length();
    if (n == 0 || n > len) return 0;
    for (std::size_t i = 0; i + n <= len; ++i)
        if (std::char_traits<char>::compare(s1.data + i, s2.data, n) == 0) return static_cast<INT>(i + 1);
    return 0;
}

}  // namespace irp::st
