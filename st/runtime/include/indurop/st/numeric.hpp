// numeric.hpp -- the standard's numeric functions: ABS, SQRT, LN, LOG, EXP, SIN, COS, TAN, ASIN,
// ACOS, ATAN, ATAN2, EXPT.  REAL and LREAL follow IEEE 754 and the C library: SQRT(-1.0) and
// LN(-1.0) are NaN, LN(0.0) is -infinity; none of them faults.  The result has the argument's type
// (a REAL stays a REAL, computed in float).
#pragma once

#include <indurop/st/arith.hpp>
#include <indurop/st/types.hpp>

#include <cmath>

namespace irp::st {

// ABS of an integer wraps: ABS(INT#-32768) = -32768 (its negation, as NEG).
template <Number T>
constexpr T ABS(T x) noexcept {
    if constexpr (Real<T>)
        return std::fabs(x);
    else if constexpr (std::is_signed_v<T>)
        return x < 0 ? NEG(x) : x;
    else
        return x;
}

#define IRP_ST_REAL_FUNCTION(NAME, FN)                                                                                 \
    template <Real T>                                                                                                  \
    inline T NAME(T x) noexcept {                                                                                      \
        return std::FN(x);                                                                                             \
    }
IRP_ST_REAL_FUNCTION(SQRT, sqrt)
IRP_ST_REAL_FUNCTION(LN, log)
IRP_ST_REAL_FUNCTION(LOG, log10)
IRP_ST_REAL_FUNCTION(EXP, exp)
IRP_ST_REAL_FUNCTION(SIN, sin)
IRP_ST_REAL_FUNCTION(COS, cos)
IRP_ST_REAL_FUNCTION(TAN, tan)
IRP_ST_REAL_FUNCTION(ASIN, asin)
IRP_ST_REAL_FUNCTION(ACOS, acos)
IRP_ST_REAL_FUNCTION(ATAN, atan)
#undef IRP_ST_REAL_FUNCTION

template <Real T>
inline T ATAN2(T y, std::type_identity_t<T> x) noexcept {
    return std::atan2(y, x);
}

// EXPT(IN1, IN2): IN1 to the power IN2, IN1 a REAL or LREAL, IN2 any number; the result has IN1's
// type.  An integer exponent is exact in sign (EXPT(-2.0, 3) = -8.0); 0.0 ** -1 is +infinity and a
// negative base to a non-integral power is NaN (IEEE pow).
template <Real T, Number E>
inline T EXPT(T base, E exponent) noexcept {
    return static_cast<T>(std::pow(static_cast<double>(base), static_cast<double>(exponent)));
}

}  // namespace irp::st
