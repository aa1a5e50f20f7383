// string_convert.hpp -- conversions to and from STRING: `<TYPE>_TO_STRING` for every elementary
// type and `STRING_TO_<TYPE>`, without allocation.
//   to STRING: BOOL as 'TRUE' / 'FALSE'; integers and bit strings in decimal; REAL and LREAL in
//   the shortest form that reads back to the same value ('1.5', '1e+20'); the time types in IEC
//   literal form: 'T#1s200ms', 'LTIME#1m5us', 'D#2024-01-31', 'TOD#12:30:15.5',
//   'DT#2024-01-31-12:30:15', 'LDATE#…', 'LTOD#…', 'LDT#…' (T#0ms for zero; a negative TIME as
//   'T#-1s').  The result is a
//   STRING (String<80>; every such text fits).
//   from STRING: the same forms, and integers also as 2#, 8#, 16# literals with '_' between digits;
//   spaces around the text are ignored; text that is not such a value gives 0 (FALSE), as
//   CODESYS; an integer too large for the target keeps the target's bits (as INT conversions).
#pragma once

#include <indurop/st/convert.hpp>
#include <indurop/st/string.hpp>
#include <indurop/st/types.hpp>

#include <charconv>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <string_view>

namespace irp::st {

namespace detail {

inline void appendUnsigned(String<> &r, uint64_t v) noexcept {
    char digits[24];
    auto [end, ec] = std::to_chars(digits, digits + sizeof digits, v);
    r.append(digits, static_cast<std::size_t>(end - digits));
}

inline void appendTwo(String<> &r, int64_t v) noexcept {
    const char two[2] = {static_cast<char>('0' + v / 10), static_cast<char>('0' + v % 10)};
    r.append(two, 2);
}

// ".5", ".000001" of the nanoseconds `ns` (< 1 s), nothing when 0.
inline void appendFraction(String<> &r, int64_t ns) noexcept {
    if (ns == 0) return;
    char f[10] = {'.'};
    for (int i = 9; i >= 1; --i, ns /= 10) f[i] = static_cast<char>('0' + ns % 10);
    std::size_t n = 10;
    while (f[n - 1] == '0') --n;
    r.append(f, n);
}

inline String<> durationText(const char *prefix, int64_t ns) noexcept {
    String<> r(prefix);
    uint64_t v = static_cast<uint64_t>(ns);
    if (ns < 0) {
        r.append("-", 1);
        v = 0 - v;
    }
    if (v == 0) r.append("0ms", 3);
    static constexpr struct {
        uint64_t ns;
        const char *unit;
    } kUnits[] = {{uint64_t(kNsPerDay), "d"},
                  {uint64_t(kNsPerHour), "h"},
                  {uint64_t(kNsPerMinute), "m"},
                  {uint64_t(kNsPerSecond), "s"},
                  {uint64_t(kNsPerMs), "ms"},
                  {uint64_t(kNsPerUs), "us"},
                  {1, "ns"}};
    for (const auto &u : kUnits) {
        if (v >= u.ns) {
            appendUnsigned(r, v / u.ns);
            r.append(u.unit, std::strlen(u.unit));
            v %= u.ns;
        }
    }
    return r;
}

inline void appendDate(String<> &r, int64_t ns) noexcept {
    using namespace std::chrono;
    const int64_t day = (ns - ((ns % kNsPerDay) + kNsPerDay) % kNsPerDay) / kNsPerDay;
    const year_month_day ymd{sys_days{days{day}}};
    const int y = static_cast<int>(ymd.year());
    if (y < 0) r.append("-", 1);
    appendUnsigned(r, static_cast<uint64_t>(y < 0 ? -y : y));
    r.append("-", 1);
    appendTwo(r, static_cast<unsigned>(ymd.month()));
    r.append("-", 1);
    appendTwo(r, static_cast<unsigned>(ymd.day()));
}

inline void appendTimeOfDay(String<> &r, int64_t ns) noexcept {
    ns = ((ns % kNsPerDay) + kNsPerDay) % kNsPerDay;
    appendTwo(r, ns / kNsPerHour);
    r.append(":", 1);
    appendTwo(r, ns / kNsPerMinute % 60);
    r.append(":", 1);
    appendTwo(r, ns / kNsPerSecond % 60);
    appendFraction(r, ns % kNsPerSecond);
}

// ---- parsing ----------------------------------------------------------------------------------

struct Text {
    const char *at;
    const char *end;
    bool done() const noexcept { return at == end; }
    char peek() const noexcept { return at == end ? '\0' : *at; }
    // Skips `word` (any case) if the text continues with it.
    bool skip(std::string_view word) noexcept {
        if (static_cast<std::size_t>(end - at) < word.size()) return false;
        for (std::size_t i = 0; i < word.size(); ++i)
            if ((at[i] | 0x20) != (word[i] | 0x20)) return false;
        at += word.size();
        return true;
    }
};

template <std::size_t N>
inline Text trimmed(const String<N> &s) noexcept {
    const char *b = s.data, *e = s.data + s.length();
    while (b < e && (*b == ' ' || *b == '\t')) ++b;
    while (e > b && (e[-1] == ' ' || e[-1] == '\t')) --e;
    return {b, e};
}

// Digits of `base` with '_' between them; false when there is none or a stray character follows
// within the number.  The value wraps modulo 2^64.
inline bool digits(Text &t, unsigned base, uint64_t &v) noexcept {
    bool any = false;
    v = 0;
    for (; !t.done(); ++t.at) {
        const char c = *t.at;
        unsigned d;
        if (c >= '0' && c <= '9')
            d = static_cast<unsigned>(c - '0');
        else if ((c | 0x20) >= 'a' && (c | 0x20) <= 'f')
            d = static_cast<unsigned>((c | 0x20) - 'a' + 10);
        else if (c == '_' && any)
            continue;
        else
            break;
        if (d >= base) break;
        v = v * base + d;
        any = true;
    }
    return any;
}

// An integer literal: [+|-] digits, or 2#, 8#, 16# digits.  The value as 64 bits (two's complement).
inline bool integerText(Text t, uint64_t &v) noexcept {
    const bool negative = t.peek() == '-';
    if (negative || t.peek() == '+') ++t.at;
    unsigned base = 10;
    if (t.skip("16#"))
        base = 16;
    else if (t.skip("8#"))
        base = 8;
    else if (t.skip("2#"))
        base = 2;
    if (!digits(t, base, v) || !t.done()) return false;
    if (negative) v = 0 - v;
    return true;
}

inline bool realText(Text t, double &v) noexcept {
    if (t.peek() == '+') ++t.at;
    auto [end, ec] = std::from_chars(t.at, t.end, v);
    return ec == std::errc() && end == t.end;
}

// A number with an optional fraction, for durations ("1.5" of T#1.5s), in units of 1e-9.
inline bool decimal(Text &t, uint64_t &whole, uint64_t &nano) noexcept {
    if (!digits(t, 10, whole)) return false;
    nano = 0;
    if (t.peek() == '.') {
        ++t.at;
        uint64_t scale = 100'000'000;
        for (; !t.done() && ((*t.at >= '0' && *t.at <= '9') || *t.at == '_'); ++t.at) {
            if (*t.at == '_') continue;
            nano += static_cast<uint64_t>(*t.at - '0') * scale;
            scale /= 10;
        }
    }
    return true;
}

inline bool durationText(Text t, int64_t &ns) noexcept {
    if (!(t.skip("LTIME#") || t.skip("LT#") || t.skip("TIME#") || t.skip("T#"))) return false;
    const bool negative = t.peek() == '-';
    if (negative) ++t.at;
    static constexpr struct {
        const char *unit;
        uint64_t ns;
    } kUnits[] = {{"ms", uint64_t(kNsPerMs)},   {"us", uint64_t(kNsPerUs)},  {"ns", 1},
                  {"d", uint64_t(kNsPerDay)},   {"h", uint64_t(kNsPerHour)}, {"m", uint64_t(kNsPerMinute)},
                  {"s", uint64_t(kNsPerSecond)}};
    uint64_t total = 0;
    bool any = false;
    while (!t.done()) {
        uint64_t whole, nano;
        if (!decimal(t, whole, nano)) return false;
        const auto *u = std::begin(kUnits);
        while (u != std::end(kUnits) && !t.skip(u->unit)) ++u;
        if (u == std::end(kUnits)) return false;
        total += whole * u->ns + nano * u->ns / 1'000'000'000;
        any = true;
        if (t.peek() == '_') ++t.at;
    }
    ns = static_cast<int64_t>(negative ? 0 - total : total);
    return any;
}

inline bool number(Text &t, int64_t &v) noexcept {
    uint64_t u;
    if (!digits(t, 10, u)) return false;
    v = static_cast<int64_t>(u);
    return true;
}

inline bool dateText(Text &t, int64_t &ns) noexcept {
    using namespace std::chrono;
    int64_t y, m, d;
    const bool negative = t.peek() == '-';
    if (negative) ++t.at;
    if (!number(t, y) || !t.skip("-") || !number(t, m) || !t.skip("-") || !number(t, d)) return false;
    const year_month_day ymd{year{static_cast<int>(negative ? -y : y)}, month{static_cast<unsigned>(m)},
                             day{static_cast<unsigned>(d)}};
    if (!ymd.ok()) return false;
    ns = sys_days{ymd}.time_since_epoch().count() * kNsPerDay;
    return true;
}

inline bool timeOfDayText(Text &t, int64_t &ns) noexcept {
    int64_t h, m;
    uint64_t s, nano;
    if (!number(t, h) || !t.skip(":") || !number(t, m) || !t.skip(":") || !decimal(t, s, nano)) return false;
    if (h > 23 || m > 59 || s > 59) return false;
    ns = h * kNsPerHour + m * kNsPerMinute + static_cast<int64_t>(s) * kNsPerSecond + static_cast<int64_t>(nano);
    return true;
}

}  // namespace detail

// ---- to STRING ----------------------------------------------------------------------------------

inline String<> BOOL_TO_STRING(bool v) noexcept { return String<>(v ? "TRUE" : "FALSE"); }

#define IRP_ST_INTEGER_TO_STRING(NAME)                                                                                 \
    inline String<> NAME##_TO_STRING(NAME v) noexcept {                                                                \
        char text[24];                                                                                                 \
        auto [end, ec] = std::to_chars(text, text + sizeof text, v);                                                   \
        String<> r;                                                                                                    \
        r.assign(text, static_cast<std::size_t>(end - text));                                                          \
        return r;                                                                                                      \
    }
IRP_ST_INTEGER_TO_STRING(SINT)
IRP_ST_INTEGER_TO_STRING(INT)
IRP_ST_INTEGER_TO_STRING(DINT)
IRP_ST_INTEGER_TO_STRING(LINT)
IRP_ST_INTEGER_TO_STRING(USINT)
IRP_ST_INTEGER_TO_STRING(UINT)
IRP_ST_INTEGER_TO_STRING(UDINT)
IRP_ST_INTEGER_TO_STRING(ULINT)
IRP_ST_INTEGER_TO_STRING(BYTE)
IRP_ST_INTEGER_TO_STRING(WORD)
IRP_ST_INTEGER_TO_STRING(DWORD)
IRP_ST_INTEGER_TO_STRING(LWORD)
IRP_ST_INTEGER_TO_STRING(REAL)
IRP_ST_INTEGER_TO_STRING(LREAL)
#undef IRP_ST_INTEGER_TO_STRING

inline String<> TIME_TO_STRING(TIME v) noexcept { return detail::durationText("T#", v); }
inline String<> LTIME_TO_STRING(LTIME v) noexcept { return detail::durationText("LTIME#", v); }

namespace detail {
inline String<> dateText(const char *prefix, int64_t v) noexcept {
    String<> r(prefix);
    appendDate(r, v);
    return r;
}
inline String<> timeOfDayText(const char *prefix, int64_t v) noexcept {
    String<> r(prefix);
    appendTimeOfDay(r, v);
    return r;
}
inline String<> dateAndTimeText(const char *prefix, int64_t v) noexcept {
    String<> r(prefix);
    appendDate(r, v);
    r.append("-", 1);
    appendTimeOfDay(r, v);
    return r;
}
}  // namespace detail

inline String<> DATE_TO_STRING(DATE v) noexcept { return detail::dateText("D#", v); }
inline String<> LDATE_TO_STRING(LDATE v) noexcept { return detail::dateText("LDATE#", v); }
inline String<> TOD_TO_STRING(TOD v) noexcept { return detail::timeOfDayText("TOD#", v); }
inline String<> LTOD_TO_STRING(LTOD v) noexcept { return detail::timeOfDayText("LTOD#", v); }
inline String<> DT_TO_STRING(DT v) noexcept { return detail::dateAndTimeText("DT#", v); }
inline String<> LDT_TO_STRING(LDT v) noexcept { return detail::dateAndTimeText("LDT#", v); }

// ---- from STRING --------------------------------------------------------------------------------

template <std::size_t N>
inline BOOL STRING_TO_BOOL(const String<N> &s) noexcept {
    detail::Text t = detail::trimmed(s);
    if (t.skip("TRUE") && t.done()) return true;
    uint64_t v;
    return detail::integerText(detail::trimmed(s), v) && v != 0;
}

#define IRP_ST_STRING_TO_INTEGER(NAME)                                                                                 \
    template <std::size_t N>                                                                                           \
    inline NAME STRING_TO_##NAME(const String<N> &s) noexcept {                                                        \
        uint64_t v;                                                                                                    \
        return detail::integerText(detail::trimmed(s), v) ? static_cast<NAME>(v) : NAME{0};                            \
    }
IRP_ST_STRING_TO_INTEGER(SINT)
IRP_ST_STRING_TO_INTEGER(INT)
IRP_ST_STRING_TO_INTEGER(DINT)
IRP_ST_STRING_TO_INTEGER(LINT)
IRP_ST_STRING_TO_INTEGER(USINT)
IRP_ST_STRING_TO_INTEGER(UINT)
IRP_ST_STRING_TO_INTEGER(UDINT)
IRP_ST_STRING_TO_INTEGER(ULINT)
IRP_ST_STRING_TO_INTEGER(BYTE)
IRP_ST_STRING_TO_INTEGER(WORD)
IRP_ST_STRING_TO_INTEGER(DWORD)
IRP_ST_STRING_TO_INTEGER(LWORD)
#undef IRP_ST_STRING_TO_INTEGER

template <std::size_t N>
inline LREAL STRING_TO_LREAL(const String<N> &s) noexcept {
    double v;
    return detail::realText(detail::trimmed(s), v) ? v : 0.0;
}
template <std::size_t N>
inline REAL STRING_TO_REAL(const String<N> &s) noexcept {
    return static_cast<REAL>(STRING_TO_LREAL(s));
}

template <std::size_t N>
inline TIME STRING_TO_TIME(const String<N> &s) noexcept {
    int64_t ns;
    return detail::durationText(detail::trimmed(s), ns) ? ns : 0;
}
template <std::size_t N>
inline LTIME STRING_TO_LTIME(const String<N> &s) noexcept {
    return STRING_TO_TIME(s);
}
namespace detail {
// The prefixes of each kind's literals, longest first (any of them is read for either length).
inline bool datePrefix(Text &t) noexcept {
    return t.skip("LDATE#") || t.skip("LD#") || t.skip("DATE#") || t.skip("D#");
}
inline bool timeOfDayPrefix(Text &t) noexcept {
    return t.skip("LTIME_OF_DAY#") || t.skip("LTOD#") || t.skip("TIME_OF_DAY#") || t.skip("TOD#");
}
inline bool dateAndTimePrefix(Text &t) noexcept {
    return t.skip("LDATE_AND_TIME#") || t.skip("LDT#") || t.skip("DATE_AND_TIME#") || t.skip("DT#");
}
template <std::size_t N>
inline int64_t dateOf(const String<N> &s) noexcept {
    Text t = trimmed(s);
    int64_t ns;
    return datePrefix(t) && dateText(t, ns) && t.done() ? ns : 0;
}
template <std::size_t N>
inline int64_t timeOfDayOf(const String<N> &s) noexcept {
    Text t = trimmed(s);
    int64_t ns;
    return timeOfDayPrefix(t) && timeOfDayText(t, ns) && t.done() ? ns : 0;
}
template <std::size_t N>
inline int64_t dateAndTimeOf(const String<N> &s) noexcept {
    Text t = trimmed(s);
    int64_t day, tod;
    return dateAndTimePrefix(t) && dateText(t, day) && t.skip("-") && timeOfDayText(t, tod) && t.done() ? day + tod : 0;
}
}  // namespace detail

#define IRP_ST_STRING_TO_POINT_IN_TIME(NAME, PARSE)                                                                    \
    template <std::size_t N>                                                                                           \
    inline NAME STRING_TO_##NAME(const String<N> &s) noexcept {                                                        \
        return detail::PARSE(s);                                                                                       \
    }
IRP_ST_STRING_TO_POINT_IN_TIME(DATE, dateOf)
IRP_ST_STRING_TO_POINT_IN_TIME(LDATE, dateOf)
IRP_ST_STRING_TO_POINT_IN_TIME(TOD, timeOfDayOf)
IRP_ST_STRING_TO_POINT_IN_TIME(LTOD, timeOfDayOf)
IRP_ST_STRING_TO_POINT_IN_TIME(DT, dateAndTimeOf)
IRP_ST_STRING_TO_POINT_IN_TIME(LDT, dateAndTimeOf)
#undef IRP_ST_STRING_TO_POINT_IN_TIME

}  // namespace irp::st
