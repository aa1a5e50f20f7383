// codec.hpp -- raw fieldbus values <-> numbers: Modbus registers (16-bit, or 32-bit pairs in
// either word order, signed, unsigned or float), CAN signals (little-endian bit fields), and the
// scaling to variables (variable = raw * scale + offset).  Pure functions, RT-safe.
#pragma once

#include "ioconfig.hpp"

#include <cstdint>

namespace irp::iodispat {

// The raw value of registerCount(f) registers starting at r.
double decodeRegisters(const uint16_t *r, Format f, WordOrder w) noexcept;
// Writes raw (rounded to the nearest integer and clamped to the format's range; NaN -> 0) to
// registerCount(f) registers starting at out.
void encodeRegisters(double raw, Format f, WordOrder w, uint16_t *out) noexcept;

inline double toVariable(double raw, const Scaling &s) noexcept { return raw * s.scale + s.offset; }
inline double toRaw(double variable, const Scaling &s) noexcept { return (variable - s.offset) / s.scale; }

// CAN signals: bit 0 is the least significant bit of data[0], bit 63 the most significant of data[7].
uint64_t extractBits(const uint8_t data[8], int start, int length) noexcept;
void insertBits(uint8_t data[8], int start, int length, uint64_t value) noexcept;
double decodeSignal(const uint8_t data[8], const CanSignal &s) noexcept;
void encodeSignal(uint8_t data[8], const CanSignal &s, double raw) noexcept;

// Rounds and clamps to [lo, hi]; NaN -> 0.
double clampRound(double v, double lo, double hi) noexcept;

}  // namespace irp::iodispat
