// test_st_runtime_strings.cpp -- STRING[n] of the ST runtime (string.hpp, string_convert.hpp;
// docs/st-runtime.md): String<N> is char[N+1] and never written past N, the string functions at
// and past their bounds (1-based positions, FIND not found = 0), comparison, assignment between
// capacities, and the conversions to and from STRING in IEC literal form.
#include <indurop/st/st.hpp>

#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <string>

using namespace irp::st;

namespace {

template <std::size_t N>
std::string str(const String<N> &s) {
    return std::string(s.data, s.length());
}

// A String<N> between two guard bytes, to see that nothing writes past N+1 bytes.
template <std::size_t N>
struct Guarded {
    char before = '#';
    String<N> s;
    char after = '#';
    bool intact() const { return before == '#' && after == '#' && s.data[N] == '\0'; }
};

}  // namespace

TEST(StString, MemoryIsExactlyCharNPlusOne) {
    static_assert(sizeof(String<80>) == 81 && sizeof(String<1>) == 2 && sizeof(String<255>) == 256);
    static_assert(alignof(String<10>) == 1);
    static_assert(std::is_trivially_copyable_v<String<10>> && std::is_standard_layout_v<String<10>>);
    static_assert(std::is_same_v<String<>, String<80>>);
    String<5> s;
    EXPECT_EQ(str(s), "");
    EXPECT_EQ(LEN(s), 0);
}

TEST(StString, AssignmentCutsAtTheCapacity) {
    Guarded<4> g;
    g.s = "ABCDEFG";
    EXPECT_EQ(str(g.s), "ABCD");
    EXPECT_TRUE(g.intact());
    String<10> wide = "0123456789";
    g.s = wide;
    EXPECT_EQ(str(g.s), "0123");
    EXPECT_TRUE(g.intact());
    g.s = String<2>("xy");
    EXPECT_EQ(str(g.s), "xy");
    EXPECT_EQ(g.s.data[2], '\0');
    EXPECT_EQ(g.s.data[3], '\0');
    String<10> back = g.s;
    EXPECT_EQ(str(back), "xy");
}

TEST(StString, LengthNeverPassesNEvenUnterminated) {
    String<3> s;
    std::memcpy(s.data, "ABCD", 4);  // as if another writer left no NUL in shared memory
    EXPECT_EQ(LEN(s), 3);
    EXPECT_EQ(str(LEFT(s, 10)), "ABC");
}

TEST(StString, LeftRightMid) {
    const String<10> s = "ABCDE";
    EXPECT_EQ(str(LEFT(s, 2)), "AB");
    EXPECT_EQ(str(LEFT(s, 0)), "");
    EXPECT_EQ(str(LEFT(s, -1)), "");
    EXPECT_EQ(str(LEFT(s, 99)), "ABCDE");
    EXPECT_EQ(str(RIGHT(s, 2)), "DE");
    EXPECT_EQ(str(RIGHT(s, 99)), "ABCDE");
    EXPECT_EQ(str(RIGHT(s, -3)), "");
    EXPECT_EQ(str(MID(s, 2, 2)), "BC");
    EXPECT_EQ(str(MID(s, 99, 4)), "DE");  // past the end: what there is
    EXPECT_EQ(str(MID(s, 2, 5)), "E");
    EXPECT_EQ(str(MID(s, 1, 6)), "");  // position past the end
    EXPECT_EQ(str(MID(s, 1, 0)), "");  // position before the start
    EXPECT_EQ(str(MID(s, -1, 2)), "");
    EXPECT_EQ(str(MID(s, 2, std::numeric_limits<uint64_t>::max())), "");
}

TEST(StString, ConcatHasRoomForAll) {
    const String<3> a = "abc";
    const String<2> b = "de";
    auto c = CONCAT(a, b);
    static_assert(decltype(c)::capacity == 5);
    EXPECT_EQ(str(c), "abcde");
    EXPECT_EQ(str(CONCAT(a, b, String("f"), String<0>())), "abcdef");
    Guarded<4> g;
    g.s = CONCAT(a, b);  // the assignment cuts
    EXPECT_EQ(str(g.s), "abcd");
    EXPECT_TRUE(g.intact());
}

TEST(StString, InsertAfterThePthCharacter) {
    const String<5> s = "ABC";
    EXPECT_EQ(str(INSERT(s, String("XY"), 2)), "ABXYC");
    EXPECT_EQ(str(INSERT(s, String("XY"), 0)), "XYABC");
    EXPECT_EQ(str(INSERT(s, String("XY"), 3)), "ABCXY");
    EXPECT_EQ(str(INSERT(s, String("XY"), 99)), "ABCXY");  // past the end: appended
    EXPECT_EQ(str(INSERT(s, String("XY"), -4)), "XYABC");
    const String<3> full = "ABC";
    auto r = INSERT(full, String<3>("DEF"), 1);
    static_assert(decltype(r)::capacity == 6);
    EXPECT_EQ(str(r), "ADEFBC");
}

TEST(StString, DeleteLCharactersFromP) {
    const String<10> s = "ABCDE";
    EXPECT_EQ(str(DELETE(s, 2, 2)), "ADE");
    EXPECT_EQ(str(DELETE(s, 99, 3)), "AB");  // past the end: up to it
    EXPECT_EQ(str(DELETE(s, 1, 5)), "ABCD");
    EXPECT_EQ(str(DELETE(s, 1, 6)), "ABCDE");  // position past the end: unchanged
    EXPECT_EQ(str(DELETE(s, 1, 0)), "ABCDE");
    EXPECT_EQ(str(DELETE(s, 0, 2)), "ABCDE");
    EXPECT_EQ(str(DELETE(s, -2, 2)), "ABCDE");
}

TEST(StString, ReplaceLCharactersFromP) {
    const String<10> s = "ABCDE";
    EXPECT_EQ(str(REPLACE(s, String("X"), 2, 3)), "ABXE");
    EXPECT_EQ(str(REPLACE(s, String("XYZ"), 1, 1)), "XYZBCDE");
    EXPECT_EQ(str(REPLACE(s, String("X"), 99, 4)), "ABCX");    // past the end: the rest replaced
    EXPECT_EQ(str(REPLACE(s, String("X"), 2, 99)), "ABCDEX");  // position past the end: appended
    EXPECT_EQ(str(REPLACE(s, String("X"), 2, -1)), "XCDE");    // before the start: from 1
    EXPECT_EQ(str(REPLACE(s, String(""), 0, 2)), "ABCDE");
}

TEST(StString, FindIsOneBasedAndZeroWhenAbsent) {
    const String<10> s = "ABCABC";
    EXPECT_EQ(FIND(s, String("BC")), 2);
    EXPECT_EQ(FIND(s, String("ABC")), 1);
    EXPECT_EQ(FIND(s, String("CA")), 3);
    EXPECT_EQ(FIND(s, String("X")), 0);
    EXPECT_EQ(FIND(s, String("ABCABCA")), 0);  // longer than s
    EXPECT_EQ(FIND(s, String("")), 0);
    EXPECT_EQ(FIND(String(""), String("A")), 0);
}

TEST(StString, ComparisonIsByteWiseAcrossCapacities) {
    EXPECT_TRUE(String<3>("abc") == String<10>("abc"));
    EXPECT_TRUE(String("abc") < String("abd"));
    EXPECT_TRUE(String("ab") < String("abc"));
    EXPECT_TRUE(String("") < String("a"));
    EXPECT_TRUE(String("\xe4") > String("z"));  // bytes compare unsigned
    EXPECT_TRUE(GT(String("b"), String("a")));
    EXPECT_TRUE(EQ(String<2>("ab"), String<5>("ab")));
    EXPECT_EQ(str(MAX(String<5>("pear"), String<5>("apple"))), "pear");
    EXPECT_EQ(str(MIN(String<5>("pear"), String<5>("apple"))), "apple");
    EXPECT_EQ(str(SEL(true, String<5>("no"), String<5>("yes"))), "yes");
    // with a literal, however long
    EXPECT_TRUE(String<5>("abc") == "abc");
    EXPECT_FALSE(String<3>("abc") == "abcd");  // not equal to a text it cannot hold
    EXPECT_TRUE(String<3>("abc") < "abcd");
    EXPECT_TRUE(String<5>("abd") > "abc");
    EXPECT_TRUE(EQ(String<5>("x"), "x"));
}

// ---- conversions ----------------------------------------------------------------------------------

TEST(StStringConvert, NumbersAndBoolsToString) {
    EXPECT_EQ(str(BOOL_TO_STRING(true)), "TRUE");
    EXPECT_EQ(str(BOOL_TO_STRING(false)), "FALSE");
    EXPECT_EQ(str(INT_TO_STRING(-32768)), "-32768");
    EXPECT_EQ(str(ULINT_TO_STRING(UINT64_MAX)), "18446744073709551615");
    EXPECT_EQ(str(BYTE_TO_STRING(255)), "255");
    EXPECT_EQ(str(REAL_TO_STRING(1.5f)), "1.5");
    EXPECT_EQ(str(REAL_TO_STRING(0.1f)), "0.1");
    EXPECT_EQ(str(LREAL_TO_STRING(-2.0)), "-2");
    EXPECT_EQ(str(LREAL_TO_STRING(1e20)), "1e+20");
}

TEST(StStringConvert, TimesToStringInIecLiteralForm) {
    EXPECT_EQ(str(TIME_TO_STRING(1'200'000'000)), "T#1s200ms");
    EXPECT_EQ(str(TIME_TO_STRING(0)), "T#0ms");
    EXPECT_EQ(str(TIME_TO_STRING(-kNsPerSecond)), "T#-1s");
    EXPECT_EQ(str(TIME_TO_STRING(kNsPerDay + 2 * kNsPerHour + 3 * kNsPerMinute + 4)), "T#1d2h3m4ns");
    EXPECT_EQ(str(TIME_TO_STRING(INT64_MIN)), "T#-106751d23h47m16s854ms775us808ns");
    EXPECT_EQ(str(LTIME_TO_STRING(61 * kNsPerSecond + 5000)), "LTIME#1m1s5us");
    EXPECT_EQ(str(DATE_TO_STRING(0)), "D#1970-01-01");
    EXPECT_EQ(str(DATE_TO_STRING(-kNsPerDay)), "D#1969-12-31");
    EXPECT_EQ(str(TOD_TO_STRING(12 * kNsPerHour + 30 * kNsPerMinute + 15 * kNsPerSecond + 500'000'000)),
              "TOD#12:30:15.5");
    EXPECT_EQ(str(TOD_TO_STRING(1)), "TOD#00:00:00.000000001");
    EXPECT_EQ(str(DT_TO_STRING(1'706'704'215LL * kNsPerSecond)), "DT#2024-01-31-12:30:15");
}

TEST(StStringConvert, StringsToNumbers) {
    EXPECT_EQ(STRING_TO_INT(String("123")), 123);
    EXPECT_EQ(STRING_TO_INT(String(" -42 ")), -42);
    EXPECT_EQ(STRING_TO_INT(String("+7")), 7);
    EXPECT_EQ(STRING_TO_WORD(String("16#FF_FF")), 0xFFFF);
    EXPECT_EQ(STRING_TO_BYTE(String("2#1010_0001")), 0xA1);
    EXPECT_EQ(STRING_TO_DINT(String("8#17")), 15);
    EXPECT_EQ(STRING_TO_INT(String("70000")), 4464);  // the target's bits
    EXPECT_EQ(STRING_TO_INT(String("12abc")), 0);     // not a number: 0
    EXPECT_EQ(STRING_TO_INT(String("")), 0);
    EXPECT_EQ(STRING_TO_INT(String("_1")), 0);
    EXPECT_EQ(STRING_TO_REAL(String("2.5e1")), 25.0f);
    EXPECT_EQ(STRING_TO_LREAL(String("-0.125")), -0.125);
    EXPECT_EQ(STRING_TO_LREAL(String("1.5x")), 0.0);
    EXPECT_TRUE(STRING_TO_BOOL(String("TRUE")));
    EXPECT_TRUE(STRING_TO_BOOL(String("true")));
    EXPECT_TRUE(STRING_TO_BOOL(String("1")));
    EXPECT_FALSE(STRING_TO_BOOL(String("FALSE")));
    EXPECT_FALSE(STRING_TO_BOOL(String("yes")));
}

TEST(StStringConvert, StringsToTimesReadTheLiterals) {
    EXPECT_EQ(STRING_TO_TIME(String("T#1s200ms")), 1'200'000'000);
    EXPECT_EQ(STRING_TO_TIME(String("TIME#1.5s")), 1'500'000'000);
    EXPECT_EQ(STRING_TO_TIME(String("t#-2m_30s")), -150 * kNsPerSecond);
    EXPECT_EQ(STRING_TO_TIME(String("T#1d2h3m4s5ms6us7ns")),
              kNsPerDay + 2 * kNsPerHour + 3 * kNsPerMinute + 4 * kNsPerSecond + 5 * kNsPerMs + 6 * kNsPerUs + 7);
    EXPECT_EQ(STRING_TO_LTIME(String("LTIME#5ns")), 5);
    EXPECT_EQ(STRING_TO_TIME(String("T#")), 0);
    EXPECT_EQ(STRING_TO_TIME(String("1s")), 0);
    EXPECT_EQ(STRING_TO_TIME(String("T#1x")), 0);
    EXPECT_EQ(STRING_TO_DATE(String("D#1970-01-02")), kNsPerDay);
    EXPECT_EQ(STRING_TO_DATE(String("DATE#2024-02-30")), 0);  // no such day
    EXPECT_EQ(STRING_TO_TOD(String("TOD#00:01:00.25")), kNsPerMinute + 250 * kNsPerMs);
    EXPECT_EQ(STRING_TO_TOD(String("TOD#24:00:00")), 0);
    EXPECT_EQ(STRING_TO_DT(String("DT#1970-01-01-00:00:01")), kNsPerSecond);
    // every time type reads back what it wrote
    for (int64_t v : {int64_t{0}, int64_t{1}, -kNsPerDay - 1, int64_t{123'456'789'012'345}, INT64_MIN, INT64_MAX})
        EXPECT_EQ(STRING_TO_TIME(TIME_TO_STRING(v)), v) << str(TIME_TO_STRING(v));
    const DT dt = STRING_TO_DT(String("DT#2024-01-31-12:30:15.5"));
    EXPECT_EQ(str(DT_TO_STRING(dt)), "DT#2024-01-31-12:30:15.5");
    EXPECT_EQ(STRING_TO_DATE(DATE_TO_STRING(DT_TO_DATE(dt))), DT_TO_DATE(dt));
    EXPECT_EQ(STRING_TO_TOD(TOD_TO_STRING(DT_TO_TOD(dt))), DT_TO_TOD(dt));
}
