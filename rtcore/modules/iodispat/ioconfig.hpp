// ioconfig.hpp -- ioconfig.xml, the I/O dispatcher's configuration (docs/io.md): the devices
// (Modbus TCP, Modbus RTU, SocketCAN), their timeouts, and what maps each register, bit or CAN
// signal to which shared variable, with scaling and safe values.
//
// parseIoConfig() checks everything that can be checked without the shared-variable layout or
// the network and throws ConfigError("file:line: what is wrong, what was expected") otherwise.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace irp::iodispat {

class ConfigError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

enum class Direction { In, Out };
enum class Table { Coil, DiscreteInput, HoldingRegister, InputRegister };
enum class Format { Bool, U16, S16, U32, S32, F32 };  // Bool for coils and discrete inputs
enum class WordOrder { HighFirst, LowFirst };         // of 32-bit values in two registers
enum class DeviceType { ModbusTcp, ModbusRtu, SocketCan };

const char *toString(Table t);
const char *toString(Format f);
const char *toString(DeviceType t);
int registerCount(Format f);  // 1 (Bool, U16, S16) or 2

// What an output sends while its device is comm-lost, and on the first exchange after it answers again.
struct Safe {
    bool hold = true;  // keep the value last sent (before the first exchange: the variable's value at start)
    double value = 0;  // in the variable's units
};

// The scaling between a raw fieldbus value and a variable: variable = raw * scale + offset.
struct Scaling {
    double scale = 1;
    double offset = 0;
};

struct ModbusMapping {
    Direction direction = Direction::In;
    Table table = Table::HoldingRegister;
    int address = 0;  // 0-based protocol address
    int unit = -1;    // -1: the device's unit id
    Format format = Format::U16;
    WordOrder words = WordOrder::HighFirst;
    std::string path;  // the shared variable (a scalar leaf)
    Scaling scaling;
    std::optional<double> fallback;  // inputs: the value while comm-lost (none: keep the last)
    Safe safe;                       // outputs
    int line = 0;
};

// A signal in a CAN frame's data, little-endian (Intel) bit numbering: bit 0 = LSB of byte 0.
struct CanSignal {
    int start = 0;   // first (least significant) bit, 0..63
    int length = 1;  // 1..64
    bool is_signed = false;
    bool is_float = false;  // IEEE float (length 32)
    std::string path;
    Scaling scaling;
    std::optional<double> fallback;
    Safe safe;
    int line = 0;
};

struct CanFrameMap {
    uint32_t id = 0;
    bool extended = false;  // 29-bit identifier
    Direction direction = Direction::In;
    int dlc = 8;  // outputs: bytes sent
    std::vector<CanSignal> signals;
    int line = 0;
};

// CiA 402 over PDOs for one node: RPDO1 (0x200 + node) carries controlword (bytes 0-1) and target
// position (int32, bytes 2-5) to the drive; TPDO1 (0x180 + node) carries statusword (bytes 0-1)
// and actual position (int32, bytes 2-5) from it.  Positions: variable = counts * scale + offset.
struct Cia402Node {
    int node = 1;  // 1..127
    Scaling scaling;
    std::string controlword, target;  // outputs
    std::string statusword, actual;   // inputs
    double controlword_safe = 0;      // 0 = disable voltage
    Safe target_safe;                 // hold by default
    int line = 0;
};

// A CiA 402 drive whose fault the dispatcher reports as an alarm (docs/io.md, "Alarms"): the
// paths of its statusword and (optionally) error code, each an input of the same device.
struct DriveConfig {
    std::string name;        // for the operator ("axis 0"); default: "drive <n>", n its index in the file
    std::string statusword;  // bit 3 (0x08): fault
    std::string error_code;  // "" = none
    int index = 0;           // among every <drive> of the file, in file order: alarm 200 + index
    int line = 0;
};

struct DeviceConfig {
    std::string name;
    std::string file;  // the ioconfig.xml it comes from (for messages)
    DeviceType type = DeviceType::ModbusTcp;
    int line = 0;
    // modbus-tcp
    std::string host;
    int port = 502;
    int unit = 1;
    // modbus-rtu
    std::string serial;  // e.g. /dev/ttyUSB0
    int baud = 19200;
    char parity = 'E';
    int data_bits = 8;
    int stop_bits = 1;
    // socketcan
    std::string interface;  // e.g. can0
    int fd = -1;            // test hook: an open descriptor carrying struct can_frame messages
    bool sync = false;      // send a SYNC (0x080) after the outputs every cycle
    bool nmt_start = true;  // CiA 402 nodes: NMT "start remote node" when the port opens
    // every device
    double timeout_ms = 2;      // Modbus: response timeout; CAN: an input frame older than this is missing
    int fail_limit = 1;         // failed rounds in a row (timeouts) before comm-lost; hard errors: at once
    double reconnect_ms = 500;  // reconnect attempts at most this often
    int divider = 1;            // exchange every divider-th cycle
    int read_gap = 8;           // Modbus: unmapped registers (bits x 16) a read block may span
    std::vector<ModbusMapping> mappings;
    std::vector<CanFrameMap> frames;
    std::vector<Cia402Node> nodes;
    std::vector<DriveConfig> drives;
};

struct IoConfig {
    std::string file;
    std::string status;    // the IO_STATUS struct's path ("" = none)
    double budget_us = 0;  // I/O time per cycle; 0 = half the basic period
    std::vector<DeviceConfig> devices;
};

IoConfig parseIoConfig(const std::string &file);
// The same from text; `name` stands for the file in messages.
IoConfig parseIoConfigText(std::string_view text, const std::string &name);

inline constexpr int kMaxDevices = 64;
inline constexpr int kMaxDrives = 256;

}  // namespace irp::iodispat
