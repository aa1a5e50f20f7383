// codec.cpp -- register and CAN-signal encodings (see codec.hpp).
#include "codec.hpp"

#include <bit>
#include <cmath>
#include <cstring>

namespace irp::iodispat {

double clampRound(double v, double lo, double hi) noexcept {
    if (std::isnan(v)) return 0;
    v = std::round(v);
    return v < lo ? lo : v > hi ? hi : v;
}

namespace {

uint32_t join(const uint16_t *r, WordOrder w) noexcept {
    const uint32_t a = r[0], b = r[1];
    return w == WordOrder::HighFirst ? (a << 16) | b : (b << 16) | a;
}

void split(uint32_t v, WordOrder w, uint16_t *out) noexcept {
    const auto hi = static_cast<uint16_t>(v >> 16), lo = static_cast<uint16_t>(v & 0xFFFF);
    out[0] = w == WordOrder::HighFirst ? hi : lo;
    out[1] = w == WordOrder::HighFirst ? lo : hi;
}

}  // namespace

double decodeRegisters(const uint16_t *r, Format f, WordOrder w) noexcept {
    switch (f) {
    case Format::Bool: return r[0] ? 1 : 0;
    case Format::U16: return r[0];
    case Format::S16: return static_cast<int16_t>(r[0]);
    case Format::U32: return join(r, w);
    case Format::S32: return static_cast<int32_t>(join(r, w));
    case Format::F32: return std::bit_cast<float>(join(r, w));
    }
    return 0;
}

void encodeRegisters(double raw, Format f, WordOrder w, uint16_t *out) noexcept {
    switch (f) {
    case Format::Bool: out[0] = raw != 0 && !std::isnan(raw) ? 1 : 0; break;
    case Format::U16: out[0] = static_cast<uint16_t>(clampRound(raw, 0, 65535)); break;
    case Format::S16: out[0] = static_cast<uint16_t>(static_cast<int16_t>(clampRound(raw, -32768, 32767))); break;
    case Format::U32: split(static_cast<uint32_t>(clampRound(raw, 0, 4294967295.0)), w, out); break;
    case Format::S32:
        split(static_cast<uint32_t>(static_cast<int32_t>(clampRound(raw, -2147483648.0, 2147483647.0))), w, out);
        break;
    case Format::F32: split(std::bit_cast<uint32_t>(static_cast<float>(std::isnan(raw) ? 0.0 : raw)), w, out); break;
    }
}

namespace {

uint64_t load(const uint8_t data[8]) noexcept {
    uint64_t v = 0;
    for (int i = 7; i >= 0; --i) v = (v << 8) | data[i];
    return v;
}

void storeWord(uint8_t data[8], uint64_t v) noexcept {
    for (int i = 0; i < 8; ++i) data[i] = static_cast<uint8_t>(v >> (8 * i));
}

uint64_t mask(int length) noexcept { return length >= 64 ? ~uint64_t{0} : (uint64_t{1} << length) - 1; }

}  // namespace

uint64_t extractBits(const uint8_t data[8], int start, int length) noexcept {
    return (load(data) >> start) & mask(length);
}

void insertBits(uint8_t data[8], int start, int length, uint64_t value) noexcept {
    const uint64_t m = mask(length) << start;
    storeWord(data, (load(data) & ~m) | ((value << start) & m));
}

double decodeSignal(const uint8_t data[8], const CanSignal &s) noexcept {
    const uint64_t bits = extractBits(data, s.start, s.length);
    if (s.is_float) return std::bit_cast<float>(static_cast<uint32_t>(bits));
    if (s.is_signed && s.length < 64 && (bits >> (s.length - 1)) & 1)
        return static_cast<double>(static_cast<int64_t>(bits | ~mask(s.length)));  // sign-extended
    if (s.is_signed) return static_cast<double>(static_cast<int64_t>(bits));
    return static_cast<double>(bits);
}

void encodeSignal(uint8_t data[8], const CanSignal &s, double raw) noexcept {
    uint64_t bits;
    if (s.is_float) {
        bits = std::bit_cast<uint32_t>(static_cast<float>(std::isnan(raw) ? 0.0 : raw));
    } else if (s.is_signed) {
        const double lo = -std::ldexp(1.0, s.length - 1), hi = std::ldexp(1.0, s.length - 1) - 1;
        const double v = clampRound(raw, lo, s.length == 64 ? 9223372036854774784.0 : hi);
        bits = static_cast<uint64_t>(static_cast<int64_t>(v));
    } else {
        const double hi = s.length == 64 ? 18446744073709549568.0 : std::ldexp(1.0, s.length) - 1;
        bits = static_cast<uint64_t>(clampRound(raw, 0, hi));
    }
    insertBits(data, s.start, s.length, bits);
}

}  // namespace irp::iodispat
