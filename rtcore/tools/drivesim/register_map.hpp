// register_map.hpp -- the drive simulator's Modbus register map (docs/io.md has the table).
// Addresses are 0-based protocol addresses (what modbus_read_registers takes); 32-bit values are
// two registers, high word first.  Axis i is 0-based.
#pragma once

namespace irp::drivesim::regs {

// Holding registers (function codes 3, 6, 16, 23): the controller's commands.
inline constexpr int kHoldingStride = 4;    // axis i at kHoldingStride * i
inline constexpr int kControlword = 0;      // uint16
inline constexpr int kModeOfOperation = 1;  // int16 (8 = cyclic synchronous position)
inline constexpr int kTargetPosition = 2;   // int32 counts, +2 high word, +3 low word

// Input registers (function code 4): the drive's feedback.
inline constexpr int kInputStride = 8;  // axis i at kInputStride * i
inline constexpr int kStatusword = 0;   // uint16
inline constexpr int kErrorCode = 1;    // uint16 (0 none, 0x8611 following error, 0x8130 comm timeout, 0xFF00 injected)
inline constexpr int kModeDisplay = 2;  // int16
inline constexpr int kActualPosition = 3;  // int32 counts, +3 high, +4 low
inline constexpr int kActualVelocity = 5;  // int32 counts/s, +5 high, +6 low
inline constexpr int kFollowingError = 7;  // int16 counts, target - actual, saturated

// Simulator-wide registers.
inline constexpr int kFaultInjection = 1000;  // holding: bit i set -> axis i faults (0xFF00); reads back 0
inline constexpr int kAxisCount = 1000;       // input: number of axes
inline constexpr int kMapVersion = 1001;      // input: this map's version (1)
inline constexpr int kSimTimeMs = 1002;       // input: uint32 simulated ms, +1002 high, +1003 low
inline constexpr int kMapVersionValue = 1;

// Loopback scratch area, for testing a master's encodings: holding registers kLoopback..+kLoopbackCount-1
// are mirrored into the input registers of the same addresses, and coils 0..kBits-1 into the
// discrete inputs of the same addresses.
inline constexpr int kLoopback = 512;
inline constexpr int kLoopbackCount = 64;
inline constexpr int kBits = 16;

inline constexpr int kRegisters = 1024;  // holding and input registers 0..1023 exist
inline constexpr int kMaxAxes = 32;      // axis inputs end below kLoopback

}  // namespace irp::drivesim::regs
