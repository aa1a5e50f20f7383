// test_st_runtime.cpp -- the ST runtime (st/runtime, docs/st-runtime.md) as generated code calls it:
// integer arithmetic that wraps, DIV and MOD faults naming the ST place, comparison, bit strings,
// the time types' arithmetic, the conversions (REAL -> INT rounding, saturation, the time units),
// the numeric and selection functions, and the loop guard.  Strings: test_st_runtime_strings.cpp;
// the process image: test_st_runtime_image.cpp; a fault inside irpd: test_faults.cpp.
#include <indurop/st/st.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

using namespace irp::st;

namespace {

constexpr Place kAt{"main.st", 12, 9, "PROGRAM Main"};

// what() of the RuntimeFault that fn throws ("" when it throws none).
template <class Fn>
std::string faultOf(Fn fn) {
    try {
        fn();
    } catch (const RuntimeFault &e) {
        return e.what();
    }
    return "";
}

template <class V>
constexpr bool kTimeToDate = requires(V v) {
    TIME_TO_DATE(v);
};
template <class V>
constexpr bool kDtToDate = requires(V v) {
    DT_TO_DATE(v);
};

template <std::size_t N>
std::string str(const String<N> &s) {
    return std::string(s.data, s.length());
}

constexpr int64_t ms(int64_t v) { return v * kNsPerMs; }
constexpr int64_t s(int64_t v) { return v * kNsPerSecond; }

}  // namespace

// ---- types ----------------------------------------------------------------------------------------

TEST(StTypes, ElementaryTypesAreThePlansCxxTypes) {
    static_assert(std::is_same_v<INT, int16_t> && std::is_same_v<UDINT, uint32_t> && std::is_same_v<LWORD, uint64_t>);
    static_assert(std::is_same_v<REAL, float> && std::is_same_v<LREAL, double> && std::is_same_v<BOOL, bool>);
    static_assert(std::is_same_v<TIME, int64_t> && std::is_same_v<DT, int64_t> && std::is_same_v<TOD, int64_t>);
    static_assert(std::is_same_v<ENUM, int16_t>);
}

// ---- arithmetic -----------------------------------------------------------------------------------

TEST(StArithmetic, IntegerOverflowWrapsAsTheType) {
    EXPECT_EQ(ADD<INT>(32767, 1), -32768);
    EXPECT_EQ(ADD<SINT>(127, 1), -128);
    EXPECT_EQ(ADD<DINT>(INT32_MAX, 1), INT32_MIN);
    EXPECT_EQ(ADD<LINT>(INT64_MAX, 1), INT64_MIN);
    EXPECT_EQ(ADD<USINT>(255, 1), 0);
    EXPECT_EQ(SUB<UINT>(0, 1), 65535);
    EXPECT_EQ(SUB<INT>(-32768, 1), 32767);
    EXPECT_EQ(MUL<INT>(300, 300), static_cast<INT>(90000 - 131072));  // 90000 mod 2^16 as signed
    EXPECT_EQ(MUL<UINT>(65535, 65535), 1);                            // no int overflow in the promotion
    EXPECT_EQ(MUL<LINT>(INT64_MAX, 2), -2);
    EXPECT_EQ(NEG<INT>(-32768), -32768);
    EXPECT_EQ(NEG<DINT>(5), -5);
    EXPECT_EQ(ADD<INT>(1, 2, 3, 4), 10);
    EXPECT_EQ(MUL<DINT>(2, 3, 4), 24);
    static_assert(ADD<INT>(32767, 1) == -32768, "usable in constant expressions");
}

TEST(StArithmetic, RealsAreIeee) {
    EXPECT_EQ(ADD<REAL>(0.5f, 0.25f), 0.75f);
    EXPECT_TRUE(std::isinf(DIV<REAL>(kAt, 1.0f, 0.0f)));
    EXPECT_TRUE(std::isnan(DIV<LREAL>(kAt, 0.0, 0.0)));
    EXPECT_EQ(NEG<LREAL>(2.0), -2.0);
}

TEST(StArithmetic, DivTruncatesTowardZeroAndModTakesTheDividendsSign) {
    EXPECT_EQ(DIV<INT>(kAt, 7, 2), 3);
    EXPECT_EQ(DIV<INT>(kAt, -7, 2), -3);
    EXPECT_EQ(MOD<INT>(kAt, 7, 2), 1);
    EXPECT_EQ(MOD<INT>(kAt, -7, 2), -1);
    EXPECT_EQ(MOD<INT>(kAt, 7, -2), 1);
    EXPECT_EQ(MOD<UDINT>(kAt, 7u, 4u), 3u);
}

TEST(StArithmetic, TheMinimumDividedByMinusOneWraps) {
    EXPECT_EQ(DIV<INT>(kAt, -32768, -1), -32768);
    EXPECT_EQ(DIV<DINT>(kAt, INT32_MIN, -1), INT32_MIN);
    EXPECT_EQ(DIV<LINT>(kAt, INT64_MIN, -1), INT64_MIN);
    EXPECT_EQ(MOD<DINT>(kAt, INT32_MIN, -1), 0);
    EXPECT_EQ(MOD<LINT>(kAt, INT64_MIN, -1), 0);
}

TEST(StArithmetic, DivisionByZeroFaultsWithThePlace) {
    EXPECT_EQ(faultOf([] { DIV<INT>(kAt, 1, 0); }), "main.st:12:9: division by zero (PROGRAM Main)");
    EXPECT_EQ(faultOf([] { DIV<ULINT>(kAt, 1, 0); }), "main.st:12:9: division by zero (PROGRAM Main)");
    EXPECT_EQ(faultOf([] { MOD<DINT>(kAt, 1, 0); }), "main.st:12:9: division by zero (MOD) (PROGRAM Main)");
    try {
        DIV<SINT>(Place{"lib.st", 3, 14, "FUNCTION Scale"}, 1, 0);
        FAIL() << "no fault";
    } catch (const std::runtime_error &e) {  // a RuntimeFault is a std::runtime_error: irpd catches it
        const auto &fault = dynamic_cast<const RuntimeFault &>(e);
        EXPECT_STREQ(fault.place().file, "lib.st");
        EXPECT_EQ(fault.place().line, 3);
        EXPECT_EQ(fault.place().column, 14);
        EXPECT_STREQ(e.what(), "lib.st:3:14: division by zero (FUNCTION Scale)");
    }
}

TEST(StArithmetic, ComparisonsAreByValueAndExtensible) {
    EXPECT_TRUE(LT(-1, 1u));  // not C++'s -1 < 1u == false
    EXPECT_TRUE(GT(UDINT{4000000000u}, DINT{-1}));
    EXPECT_TRUE(EQ(INT{5}, LINT{5}));
    EXPECT_TRUE(NE(1.5, 2.5));
    EXPECT_TRUE(GT(3, 2, 1));
    EXPECT_FALSE(GT(3, 2, 2));
    EXPECT_TRUE(GE(3, 2, 2));
    EXPECT_TRUE(LE(1, 1, 2));
    EXPECT_FALSE(LT(1, 1, 2));
    EXPECT_TRUE(EQ(7, 7, 7));
    EXPECT_FALSE(EQ(7, 7, 8));
    EXPECT_FALSE(LT(std::nan(""), 1.0));
}

// ---- bit strings ----------------------------------------------------------------------------------

TEST(StBits, LogicOnBitStringsAndBool) {
    EXPECT_EQ(AND<BYTE>(0xF0, 0x3C), 0x30);
    EXPECT_EQ(OR<WORD>(0xF000, 0x000F, 0x0F00), 0xFF0F);
    EXPECT_EQ(XOR<BYTE>(0xFF, 0x0F), 0xF0);
    EXPECT_EQ(NOT<BYTE>(0x0F), 0xF0);
    EXPECT_EQ(NOT<DWORD>(0), 0xFFFFFFFFu);
    EXPECT_TRUE(AND(true, true, true));
    EXPECT_FALSE(AND(true, false));
    EXPECT_TRUE(XOR(true, false));
    EXPECT_FALSE(NOT(true));
}

TEST(StBits, ShiftsByTheWidthOrMoreGiveZero) {
    EXPECT_EQ(SHL<BYTE>(0x81, 1), 0x02);
    EXPECT_EQ(SHR<BYTE>(0x81, 1), 0x40);
    EXPECT_EQ(SHL<BYTE>(0x81, 7), 0x80);
    EXPECT_EQ(SHL<BYTE>(0x81, 8), 0);
    EXPECT_EQ(SHR<WORD>(0x8000, 16), 0);
    EXPECT_EQ(SHL<LWORD>(1, 63), 0x8000000000000000u);
    EXPECT_EQ(SHL<LWORD>(1, 64), 0u);
    EXPECT_EQ(SHR<LWORD>(~0ull, 100), 0u);
    EXPECT_EQ(SHL<DWORD>(1, -1), 0u);
    EXPECT_EQ(SHR<INT>(-32768, 15), 1);  // logical: no sign fill
}

TEST(StBits, RotationsAreModuloTheWidth) {
    EXPECT_EQ(ROL<BYTE>(0x81, 1), 0x03);
    EXPECT_EQ(ROL<BYTE>(0x81, 9), 0x03);
    EXPECT_EQ(ROR<BYTE>(0x81, 1), 0xC0);
    EXPECT_EQ(ROR<BYTE>(0x81, 8), 0x81);
    EXPECT_EQ(ROL<WORD>(0x8001, 4), 0x0018);
    EXPECT_EQ(ROR<DWORD>(1, 33), 0x80000000u);
    EXPECT_EQ(ROL<LWORD>(0x8000000000000000ull, 1), 1u);
    EXPECT_EQ(ROL<BYTE>(0x81, -1), ROR<BYTE>(0x81, 1));
}

TEST(StBits, BitAccessReadsAndWritesOneBit) {
    WORD w = 0x0008;
    EXPECT_TRUE(getBit<3>(w));
    EXPECT_FALSE(getBit<2>(w));
    setBit<15>(w, true);
    EXPECT_EQ(w, 0x8008);
    setBit<3>(w, false);
    EXPECT_EQ(w, 0x8000);
    INT i = 0;
    setBit<15>(i, true);
    EXPECT_EQ(i, -32768);
    EXPECT_TRUE(getBit<15>(i));
    BYTE b = 0xFF;
    setBit<0>(b, false);
    EXPECT_EQ(b, 0xFE);
}

// ---- time -----------------------------------------------------------------------------------------

TEST(StTime, DurationsAddSubtractMultiplyAndDivide) {
    EXPECT_EQ(ADD_TIME(s(1), ms(200)), ms(1200));
    EXPECT_EQ(SUB_TIME(ms(200), s(1)), ms(-800));
    EXPECT_EQ(MUL_TIME(ms(1500), 2), s(3));
    EXPECT_EQ(MUL_TIME(s(1), 1.5), ms(1500));
    EXPECT_EQ(MUL_TIME(s(1), 0.5f), ms(500));
    EXPECT_EQ(MUL_TIME(1, 0.5), 0);  // 0.5 ns rounds to even
    EXPECT_EQ(DIV_TIME(kAt, s(1), 4), ms(250));
    EXPECT_EQ(DIV_TIME(kAt, s(1), 0.5), s(2));
    EXPECT_EQ(DIV_TIME(kAt, s(1), UDINT{3}), 333333333);
    EXPECT_EQ(MUL_LTIME(7, 3), 21);
    EXPECT_EQ(ADD_LTIME(1, 2), 3);
    EXPECT_EQ(ADD_TIME(INT64_MAX, 1), INT64_MIN);  // wraps, no UB
}

TEST(StTime, DivisionOfATimeByZeroFaults) {
    EXPECT_EQ(faultOf([] { DIV_TIME(kAt, s(1), 0); }), "main.st:12:9: division of a TIME by zero (PROGRAM Main)");
    EXPECT_EQ(faultOf([] { DIV_TIME(kAt, s(1), 0.0); }), "main.st:12:9: division of a TIME by zero (PROGRAM Main)");
    EXPECT_EQ(faultOf([] { DIV_LTIME(kAt, 5, 0); }), "main.st:12:9: division of a TIME by zero (PROGRAM Main)");
}

TEST(StTime, DatesAndTimesOfDay) {
    const DATE d = STRING_TO_DATE(String("D#2024-02-28"));
    const TOD t = STRING_TO_TOD(String("TOD#23:00:00"));
    const DT dt = CONCAT_DATE_TOD(d, t);
    EXPECT_EQ(DT_TO_STRING(dt), String("DT#2024-02-28-23:00:00"));
    EXPECT_EQ(DT_TO_STRING(ADD_DT_TIME(dt, 2 * kNsPerHour)), String("DT#2024-02-29-01:00:00"));  // leap day
    EXPECT_EQ(ADD_TOD_TIME(t, 2 * kNsPerHour), kNsPerHour);  // a time of day stays in its day
    EXPECT_EQ(SUB_TOD_TIME(kNsPerHour, 2 * kNsPerHour), 23 * kNsPerHour);
    EXPECT_EQ(SUB_TOD_TOD(kNsPerHour, 2 * kNsPerHour), -kNsPerHour);
    EXPECT_EQ(SUB_DATE_DATE(STRING_TO_DATE(String("D#2024-03-01")), d), 2 * kNsPerDay);
    EXPECT_EQ(SUB_DT_DT(ADD_DT_TIME(dt, s(5)), dt), s(5));
    EXPECT_EQ(SUB_DT_TIME(dt, t), d);
    EXPECT_EQ(DT_TO_DATE(dt), d);
    EXPECT_EQ(DT_TO_TOD(dt), t);
    EXPECT_EQ(DATE_TO_DT(d), d);
    EXPECT_EQ(DT_TO_DATE(-1), -kNsPerDay);  // 1969-12-31 23:59:59.999999999 is on 1969-12-31
    EXPECT_EQ(DT_TO_TOD(-1), kNsPerDay - 1);
}

// ---- conversions ----------------------------------------------------------------------------------

TEST(StConvert, RealToIntegerRoundsToNearestTiesToEven) {
    EXPECT_EQ(REAL_TO_INT(1.5f), 2);
    EXPECT_EQ(REAL_TO_INT(2.5f), 2);
    EXPECT_EQ(REAL_TO_INT(3.5f), 4);
    EXPECT_EQ(REAL_TO_INT(-1.5f), -2);
    EXPECT_EQ(REAL_TO_INT(-2.5f), -2);
    EXPECT_EQ(REAL_TO_INT(1.4f), 1);
    EXPECT_EQ(REAL_TO_INT(-1.4f), -1);
    EXPECT_EQ(LREAL_TO_DINT(2.5000001), 3);
    EXPECT_EQ(LREAL_TO_LINT(-0.5), 0);
    EXPECT_EQ(LREAL_TO_UDINT(0.5), 0u);
    EXPECT_EQ(LREAL_TO_UDINT(1.5), 2u);
    EXPECT_EQ(REAL_TO_WORD(65535.4f), 65535);
}

TEST(StConvert, RealOutOfRangeSaturatesAndNanIsZero) {
    EXPECT_EQ(REAL_TO_INT(1e9f), 32767);
    EXPECT_EQ(REAL_TO_INT(-1e9f), -32768);
    EXPECT_EQ(REAL_TO_UINT(-1.0f), 0);
    EXPECT_EQ(LREAL_TO_LINT(1e300), INT64_MAX);
    EXPECT_EQ(LREAL_TO_LINT(-1e300), INT64_MIN);
    EXPECT_EQ(LREAL_TO_ULINT(1e300), UINT64_MAX);
    EXPECT_EQ(LREAL_TO_DINT(std::numeric_limits<double>::infinity()), INT32_MAX);
    EXPECT_EQ(LREAL_TO_DINT(std::nan("")), 0);
    EXPECT_EQ(LREAL_TO_REAL(1e300), std::numeric_limits<float>::infinity());
}

TEST(StConvert, IntegerToIntegerKeepsTheTargetsBits) {
    EXPECT_EQ(DINT_TO_INT(70000), 4464);
    EXPECT_EQ(INT_TO_UINT(-1), 65535);
    EXPECT_EQ(UINT_TO_INT(65535), -1);
    EXPECT_EQ(INT_TO_DINT(-5), -5);
    EXPECT_EQ(LINT_TO_SINT(-129), 127);
    EXPECT_EQ(WORD_TO_BYTE(0x1234), 0x34);
    EXPECT_EQ(BYTE_TO_SINT(0xFF), -1);
    EXPECT_EQ(SINT_TO_LWORD(-1), UINT64_MAX);
    EXPECT_EQ(DINT_TO_REAL(16777217), 16777216.0f);  // the nearest float
    EXPECT_EQ(ULINT_TO_LREAL(UINT64_MAX), 18446744073709551616.0);
}

TEST(StConvert, BoolIsZeroOrOne) {
    EXPECT_EQ(BOOL_TO_INT(true), 1);
    EXPECT_EQ(BOOL_TO_REAL(true), 1.0f);
    EXPECT_EQ(BOOL_TO_TIME(true), ms(1));
    EXPECT_TRUE(INT_TO_BOOL(-3));
    EXPECT_FALSE(DWORD_TO_BOOL(0));
    EXPECT_TRUE(REAL_TO_BOOL(0.1f));
    EXPECT_FALSE(TIME_TO_BOOL(0));
}

TEST(StConvert, TimeTypesConvertInTheirUnits) {
    EXPECT_EQ(TIME_TO_DINT(ms(1234)), 1234);
    EXPECT_EQ(TIME_TO_DINT(1'999'999), 1);  // toward zero
    EXPECT_EQ(TIME_TO_DINT(-1'999'999), -1);
    EXPECT_EQ(DINT_TO_TIME(1500), ms(1500));
    EXPECT_EQ(TIME_TO_REAL(ms(1) + 500'000), 1.5f);
    EXPECT_EQ(REAL_TO_TIME(1.5f), 1'500'000);  // milliseconds, kept to the nanosecond
    EXPECT_EQ(LTIME_TO_LINT(s(1)), 1'000'000'000);
    EXPECT_EQ(LINT_TO_LTIME(5), 5);
    EXPECT_EQ(TIME_TO_LTIME(ms(3)), ms(3));
    EXPECT_EQ(LTIME_TO_TIME(7), 7);
    EXPECT_EQ(DT_TO_UDINT(s(1'700'000'000)), 1'700'000'000u);
    EXPECT_EQ(UDINT_TO_DATE(86400), kNsPerDay);
    EXPECT_EQ(TOD_TO_UDINT(kNsPerHour), 3'600'000u);
    EXPECT_EQ(DINT_TO_TOD(1000), s(1));
    EXPECT_EQ(ULINT_TO_TIME(UINT64_MAX), -kNsPerMs);  // wraps as int64
}

TEST(StConvert, OnlyTheStandardsTimeConversionsExist) {
    static_assert(convertible(Iec::DATE, Iec::DT) && convertible(Iec::TOD, Iec::DT) && convertible(Iec::DT, Iec::DATE));
    static_assert(convertible(Iec::LTIME, Iec::TIME) && convertible(Iec::TIME, Iec::LTIME));
    static_assert(!convertible(Iec::TIME, Iec::DATE) && !convertible(Iec::DATE, Iec::TOD));
    static_assert(!convertible(Iec::TOD, Iec::TIME) && !convertible(Iec::DT, Iec::TIME));
    static_assert(convertible(Iec::REAL, Iec::DATE) && convertible(Iec::BOOL, Iec::TOD));
    // the names the table refuses do not resolve
    static_assert(!kTimeToDate<int64_t> && kDtToDate<int64_t>);
}

TEST(StConvert, TheLongDateTypesCountNanoseconds) {
    static_assert(convertible(Iec::LDATE, Iec::LDT) && convertible(Iec::LTOD, Iec::LDT) &&
                  convertible(Iec::DT, Iec::LDT));
    static_assert(convertible(Iec::LDATE, Iec::DATE) && convertible(Iec::TOD, Iec::LTOD) &&
                  convertible(Iec::LDT, Iec::DATE));
    static_assert(!convertible(Iec::LDATE, Iec::LTOD) && !convertible(Iec::LTOD, Iec::LDATE) &&
                  !convertible(Iec::LTIME, Iec::LDT));
    const LDT ldt = 3 * kNsPerDay + 5;
    EXPECT_EQ(LDT_TO_LDATE(ldt), 3 * kNsPerDay);
    EXPECT_EQ(LDT_TO_LTOD(ldt), 5);
    EXPECT_EQ(LDT_TO_DT(ldt), ldt);
    EXPECT_EQ(LDT_TO_DATE(ldt), 3 * kNsPerDay);
    EXPECT_EQ(LDATE_TO_DATE(kNsPerDay), kNsPerDay);
    EXPECT_EQ(LDT_TO_LINT(ldt), ldt);  // nanoseconds, where DT_TO_LINT gives seconds
    EXPECT_EQ(DT_TO_LINT(ldt), 3 * 86400);
    EXPECT_EQ(LINT_TO_LTOD(7), 7);
    EXPECT_EQ(str(LDT_TO_STRING(ldt)), "LDT#1970-01-04-00:00:00.000000005");
    EXPECT_EQ(str(LDATE_TO_STRING(kNsPerDay)), "LDATE#1970-01-02");
    EXPECT_EQ(str(LTOD_TO_STRING(kNsPerHour)), "LTOD#01:00:00");
    EXPECT_EQ(STRING_TO_LDT(LDT_TO_STRING(ldt)), ldt);
    EXPECT_EQ(STRING_TO_LDATE(String("LDATE#1970-01-02")), kNsPerDay);
    EXPECT_EQ(STRING_TO_LTOD(String("LTOD#01:00:00")), kNsPerHour);
    EXPECT_EQ(STRING_TO_DATE(String("LD#1970-01-02")), kNsPerDay);  // either length's prefix reads
}

TEST(StConvert, TruncGoesTowardZeroAndSaturates) {
    EXPECT_EQ(TRUNC(1.9f), 1);
    EXPECT_EQ(TRUNC(-1.9), -1);
    static_assert(std::is_same_v<decltype(TRUNC(1.0)), DINT>);
    EXPECT_EQ(TRUNC(1e12), INT32_MAX);
    EXPECT_EQ(TRUNC_INT(-40000.5), -32768);
    EXPECT_EQ(TRUNC_LINT(-2.7), -2);
    EXPECT_EQ(TRUNC_USINT(-2.7), 0);
    EXPECT_EQ(TRUNC_DINT(std::nan("")), 0);
    EXPECT_EQ(REAL_TRUNC_INT(-2.7f), -2);  // the 3rd edition's spelling
    EXPECT_EQ(LREAL_TRUNC_UDINT(5e9), UINT32_MAX);
}

// ---- numeric --------------------------------------------------------------------------------------

TEST(StNumeric, AbsWrapsForTheMinimum) {
    EXPECT_EQ(ABS<INT>(-5), 5);
    EXPECT_EQ(ABS<INT>(-32768), -32768);
    EXPECT_EQ(ABS<UDINT>(7u), 7u);
    EXPECT_EQ(ABS(-2.5f), 2.5f);
}

TEST(StNumeric, FunctionsOfRealsAreIeee) {
    EXPECT_FLOAT_EQ(SQRT(2.0f), std::sqrt(2.0f));
    EXPECT_TRUE(std::isnan(SQRT(-1.0)));
    EXPECT_DOUBLE_EQ(LN(std::exp(1.0)), 1.0);
    EXPECT_EQ(LN(0.0), -std::numeric_limits<double>::infinity());
    EXPECT_DOUBLE_EQ(LOG(1000.0), 3.0);
    EXPECT_DOUBLE_EQ(EXP(0.0), 1.0);
    EXPECT_NEAR(SIN(M_PI / 2), 1.0, 1e-15);
    EXPECT_NEAR(COS(0.0), 1.0, 1e-15);
    EXPECT_NEAR(TAN(M_PI / 4), 1.0, 1e-15);
    EXPECT_NEAR(ASIN(1.0), M_PI / 2, 1e-15);
    EXPECT_NEAR(ACOS(1.0), 0.0, 1e-15);
    EXPECT_NEAR(ATAN(1.0), M_PI / 4, 1e-15);
    EXPECT_NEAR(ATAN2(1.0, -1.0), 3 * M_PI / 4, 1e-15);
    EXPECT_TRUE(std::isnan(ASIN(2.0)));
    static_assert(std::is_same_v<decltype(SQRT(2.0f)), float>);
}

TEST(StNumeric, ExptRaisesARealToAnyNumber) {
    EXPECT_EQ(EXPT(2.0, 10), 1024.0);
    EXPECT_EQ(EXPT(-2.0, 3), -8.0);
    EXPECT_EQ(EXPT(2.0f, -1), 0.5f);
    EXPECT_DOUBLE_EQ(EXPT(9.0, 0.5), 3.0);
    EXPECT_TRUE(std::isnan(EXPT(-8.0, 1.0 / 3)));
    EXPECT_EQ(EXPT(0.0, -1), std::numeric_limits<double>::infinity());
    static_assert(std::is_same_v<decltype(EXPT(2.0f, 2)), float>);
}

// ---- selection ------------------------------------------------------------------------------------

TEST(StSelect, SelMaxMinMove) {
    EXPECT_EQ(SEL(false, 1, 2), 1);
    EXPECT_EQ(SEL(true, 1, 2), 2);
    EXPECT_EQ(MAX(3, 9, 4), 9);
    EXPECT_EQ(MIN(3, 9, 4, -2), -2);
    EXPECT_EQ(MAX<REAL>(1.5f, -2), 1.5f);
    EXPECT_EQ(MIN(ms(5), ms(3)), ms(3));
    EXPECT_EQ(MOVE(42), 42);
}

TEST(StSelect, LimitIsMinOfMaxEvenWhenMinIsAboveMax) {
    EXPECT_EQ(LIMIT(0, 5, 10), 5);
    EXPECT_EQ(LIMIT(0, -5, 10), 0);
    EXPECT_EQ(LIMIT(0, 15, 10), 10);
    EXPECT_EQ(LIMIT(10, 5, 0), 0);  // MN > MX: MIN(MAX(5, 10), 0) = 0 = MX
    EXPECT_EQ(LIMIT(10, 20, 0), 0);
    EXPECT_EQ(LIMIT(0.0, 0.5, 1.0), 0.5);
}

TEST(StSelect, MuxPicksTheKthInputAndFaultsOutOfRange) {
    EXPECT_EQ(MUX(kAt, 0, 10, 20, 30), 10);
    EXPECT_EQ(MUX(kAt, USINT{2}, 10, 20, 30), 30);
    EXPECT_EQ(MUX(kAt, 0, String("only")), String("only"));
    EXPECT_EQ(faultOf([] { MUX(kAt, 3, 10, 20, 30); }), "main.st:12:9: MUX selector 3 is outside 0..2 (PROGRAM Main)");
    EXPECT_EQ(faultOf([] { MUX(kAt, -1, 10, 20); }), "main.st:12:9: MUX selector -1 is outside 0..1 (PROGRAM Main)");
    EXPECT_EQ(faultOf([] { MUX(kAt, UINT64_MAX, 10, 20); }),
              "main.st:12:9: MUX selector 18446744073709551615 is outside 0..1 (PROGRAM Main)");
}

// ---- checks -----------------------------------------------------------------------------------------

TEST(StChecks, ArrayIndexIsCheckedAgainstItsRange) {
    EXPECT_EQ(index(kAt, 1, 1, 10), 0u);
    EXPECT_EQ(index(kAt, INT{10}, 1, 10), 9u);
    EXPECT_EQ(index(kAt, -3, -5, 5), 2u);
    EXPECT_EQ(faultOf([] { index(kAt, 11, 1, 10); }),
              "main.st:12:9: index 11 is outside the array's range 1..10 (PROGRAM Main)");
    EXPECT_EQ(faultOf([] { index(kAt, 0, 1, 10); }),
              "main.st:12:9: index 0 is outside the array's range 1..10 (PROGRAM Main)");
    EXPECT_EQ(faultOf([] { index(kAt, UINT64_MAX, 0, 3); }),
              "main.st:12:9: index 18446744073709551615 is outside the array's range 0..3 (PROGRAM Main)");
}

TEST(StChecks, SubrangeAssignmentIsChecked) {
    EXPECT_EQ(range(kAt, INT{5}, 0, 100), 5);
    EXPECT_EQ(range(kAt, INT{-10}, -10, 10), -10);
    EXPECT_EQ(faultOf([] { range(kAt, INT{101}, 0, 100); }),
              "main.st:12:9: value 101 is outside the subrange 0..100 (PROGRAM Main)");
    EXPECT_EQ(faultOf([] { range(kAt, DINT{-1}, 0, 100); }),
              "main.st:12:9: value -1 is outside the subrange 0..100 (PROGRAM Main)");
}

// ---- the loop guard -------------------------------------------------------------------------------

TEST(StLoop, AnAbortRequestFaultsNamingTheLoopsLine) {
    constexpr Place loop{"main.st", 30, 5, "PROGRAM Main"};
    EXPECT_EQ(faultOf([&] { loopCheck(loop, false); }), "");
    EXPECT_EQ(faultOf([&] { loopCheck(loop, true); }),
              "main.st:30:5: the run passed its overrun limit in the loop at line 30: endless loop? (PROGRAM Main)");
    // outside a run irpd asks nothing: the loop goes on
    EXPECT_FALSE(irp::st::runAbortRequested());
    EXPECT_EQ(faultOf([&] { loopCheck(loop); }), "");
}

TEST(StCycle, TheCycleTimeIsZeroOutsideARun) { EXPECT_EQ(cycleTime(), 0); }
