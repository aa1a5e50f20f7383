// time.hpp -- arithmetic on TIME, LTIME, DATE, TIME_OF_DAY and DATE_AND_TIME (all int64 nanoseconds,
// types.hpp) by the standard's named functions (IEC 61131-3 3rd edition, table 37).  The compiler
// turns `+`, `-`, `*`, `/` on these types into them and refuses the combinations the standard does
// not define (DATE + TIME, TIME * TIME, ...):
//   TIME + TIME    ADD_TIME          TOD + TIME  ADD_TOD_TIME     DT + TIME   ADD_DT_TIME
//   TIME - TIME    SUB_TIME          TOD - TIME  SUB_TOD_TIME     DT - TIME   SUB_DT_TIME
//   DATE - DATE    SUB_DATE_DATE     TOD - TOD   SUB_TOD_TOD      DT - DT     SUB_DT_DT
//   TIME * ANY_NUM MUL_TIME          TIME / ANY_NUM  DIV_TIME     CONCAT_DATE_TOD(DATE, TOD) -> DT
// and the LTIME forms (ADD_LTIME, SUB_LTIME, MUL_LTIME, DIV_LTIME).  Sums and differences wrap as
// int64 (292 years either way); a TIME_OF_DAY stays within its day (TOD#23:00 + T#2h = TOD#01:00).
#pragma once

#include <indurop/st/arith.hpp>
#include <indurop/st/convert.hpp>
#include <indurop/st/fault.hpp>
#include <indurop/st/types.hpp>

namespace irp::st {

namespace detail {
constexpr int64_t floorMod(int64_t v, int64_t m) noexcept { return ((v % m) + m) % m; }
}  // namespace detail

constexpr TIME ADD_TIME(TIME a, TIME b) noexcept { return ADD(a, b); }
constexpr TIME SUB_TIME(TIME a, TIME b) noexcept { return SUB(a, b); }
constexpr LTIME ADD_LTIME(LTIME a, LTIME b) noexcept { return ADD(a, b); }
constexpr LTIME SUB_LTIME(LTIME a, LTIME b) noexcept { return SUB(a, b); }
constexpr TOD ADD_TOD_TIME(TOD a, TIME b) noexcept { return detail::floorMod(ADD(a, b), kNsPerDay); }
constexpr TOD SUB_TOD_TIME(TOD a, TIME b) noexcept { return detail::floorMod(SUB(a, b), kNsPerDay); }
constexpr TIME SUB_TOD_TOD(TOD a, TOD b) noexcept { return SUB(a, b); }
constexpr DT ADD_DT_TIME(DT a, TIME b) noexcept { return ADD(a, b); }
constexpr DT SUB_DT_TIME(DT a, TIME b) noexcept { return SUB(a, b); }
constexpr TIME SUB_DT_DT(DT a, DT b) noexcept { return SUB(a, b); }
constexpr TIME SUB_DATE_DATE(DATE a, DATE b) noexcept { return SUB(a, b); }
constexpr DT CONCAT_DATE_TOD(DATE d, TOD t) noexcept { return ADD(d, t); }

// TIME * ANY_NUM: an integer factor wraps as int64; a REAL one rounds to the nanosecond (ties to
// even) and saturates, as REAL_TO_LINT.
template <Number N>
inline TIME MUL_TIME(TIME t, N factor) noexcept {
    if constexpr (Real<N>)
        return roundToInteger<int64_t>(static_cast<double>(t) * static_cast<double>(factor));
    else
        return MUL(t, static_cast<int64_t>(factor));
}
// TIME / ANY_NUM: an integer divisor truncates toward zero; a REAL one rounds to the nanosecond;
// a zero divisor of either kind faults (a TIME has no infinity).
template <Number N>
inline TIME DIV_TIME(const Place &place, TIME t, N divisor) {
    if (divisor == 0) [[unlikely]]
        fault(place, "division of a TIME by zero");
    if constexpr (Real<N>)
        return roundToInteger<int64_t>(static_cast<double>(t) / static_cast<double>(divisor));
    else if constexpr (std::is_unsigned_v<N>)
        return divisor > static_cast<uint64_t>(INT64_MAX) ? 0 : t / static_cast<int64_t>(divisor);
    else
        return DIV(place, t, static_cast<int64_t>(divisor));
}
template <Number N>
inline LTIME MUL_LTIME(LTIME t, N factor) noexcept {
    return MUL_TIME(t, factor);
}
template <Number N>
inline LTIME DIV_LTIME(const Place &place, LTIME t, N divisor) {
    return DIV_TIME(place, t, divisor);
}

}  // namespace irp::st
