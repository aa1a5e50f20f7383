// ioconfig.cpp -- parses and checks ioconfig.xml (pugixml); every refusal names file:line and
// the attribute, and says what was expected.
#include "ioconfig.hpp"

#include <pugixml.hpp>

#include <arpa/inet.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

namespace irp::iodispat {

const char *toString(Table t) {
    switch (t) {
    case Table::Coil: return "coil";
    case Table::DiscreteInput: return "discrete";
    case Table::HoldingRegister: return "holding";
    case Table::InputRegister: return "input";
    }
    return "?";
}

const char *toString(Format f) {
    switch (f) {
    case Format::Bool: return "bool";
    case Format::U16: return "u16";
    case Format::S16: return "s16";
    case Format::U32: return "u32";
    case Format::S32: return "s32";
    case Format::F32: return "f32";
    }
    return "?";
}

const char *toString(DeviceType t) {
    switch (t) {
    case DeviceType::ModbusTcp: return "modbus-tcp";
    case DeviceType::ModbusRtu: return "modbus-rtu";
    case DeviceType::SocketCan: return "socketcan";
    }
    return "?";
}

int registerCount(Format f) { return f == Format::U32 || f == Format::S32 || f == Format::F32 ? 2 : 1; }

namespace {

// One element being read: its attributes, checked one by one, and the unknown ones refused.
class Element {
public:
    Element(pugi::xml_node node, const std::string &file, std::string_view text)
        : node_(node), file_(file), text_(text) {}

    int line() const {
        const auto offset = static_cast<std::size_t>(std::max<std::ptrdiff_t>(0, node_.offset_debug()));
        return 1 +
               static_cast<int>(std::count(
                   text_.begin(), text_.begin() + static_cast<std::ptrdiff_t>(std::min(offset, text_.size())), '\n'));
    }
    std::string where() const { return file_ + ":" + std::to_string(line()) + ": <" + node_.name() + ">"; }

    [[noreturn]] void fail(const std::string &what) const { throw ConfigError(where() + ": " + what); }

    bool has(const char *name) {
        known_.insert(name);
        return !node_.attribute(name).empty();
    }

    std::string text(const char *name, const char *fallback = nullptr) {
        known_.insert(name);
        pugi::xml_attribute a = node_.attribute(name);
        if (a.empty()) {
            if (!fallback) fail(std::string("attribute '") + name + "' is required");
            return fallback;
        }
        std::string v = a.value();
        if (v.empty()) fail(std::string("attribute '") + name + "' is empty");
        return v;
    }

    double number(const char *name, double fallback, double lo, double hi) {
        if (!has(name)) return fallback;
        return parseNumber(name, node_.attribute(name).value(), lo, hi);
    }

    double parseNumber(const char *name, const std::string &v, double lo, double hi) const {
        char *end = nullptr;
        errno = 0;
        const double x = std::strtod(v.c_str(), &end);
        if (v.empty() || *end || errno || !std::isfinite(x))
            fail(std::string("attribute '") + name + "': expected a number, got '" + v + "'");
        if (x < lo || x > hi) {
            std::ostringstream s;
            s << "attribute '" << name << "': " << v << " is outside " << lo << ".." << hi;
            fail(s.str());
        }
        return x;
    }

    long long integer(const char *name, long long fallback, long long lo, long long hi) {
        if (!has(name)) return fallback;
        const std::string v = node_.attribute(name).value();
        char *end = nullptr;
        errno = 0;
        const long long x = std::strtoll(v.c_str(), &end, 0);  // decimal, 0x hex
        if (v.empty() || *end || errno)
            fail(std::string("attribute '") + name + "': expected an integer (decimal or 0x hex), got '" + v + "'");
        if (x < lo || x > hi)
            fail(std::string("attribute '") + name + "': " + v + " is outside " + std::to_string(lo) + ".." +
                 std::to_string(hi));
        return x;
    }

    bool boolean(const char *name, bool fallback) {
        if (!has(name)) return fallback;
        const std::string v = node_.attribute(name).value();
        if (v == "true" || v == "1" || v == "yes") return true;
        if (v == "false" || v == "0" || v == "no") return false;
        fail(std::string("attribute '") + name + "': expected true or false, got '" + v + "'");
    }

    template <class E>
    E choice(const char *name, std::initializer_list<std::pair<const char *, E>> choices,
             std::optional<E> fallback = std::nullopt) {
        if (!has(name)) {
            if (!fallback) fail(std::string("attribute '") + name + "' is required (" + list(choices) + ")");
            return *fallback;
        }
        const std::string v = node_.attribute(name).value();
        for (const auto &[text, value] : choices)
            if (v == text) return value;
        fail(std::string("attribute '") + name + "': '" + v + "' is not one of " + list(choices));
    }

    // Every attribute must have been asked for: a misspelt one is an error, not ignored.
    void done() const {
        for (pugi::xml_attribute a : node_.attributes())
            if (!known_.count(a.name())) {
                std::string names;
                for (const std::string &k : known_) names += (names.empty() ? "" : ", ") + k;
                fail(std::string("unknown attribute '") + a.name() + "' (known here: " + names + ")");
            }
    }

    pugi::xml_node node() const { return node_; }

private:
    template <class E>
    static std::string list(std::initializer_list<std::pair<const char *, E>> choices) {
        std::string s;
        for (const auto &c : choices) s += (s.empty() ? "" : ", ") + std::string(c.first);
        return s;
    }

    pugi::xml_node node_;
    const std::string &file_;
    std::string_view text_;
    std::set<std::string> known_;
};

std::optional<double> fallbackOf(Element &e, Direction d) {
    if (!e.has("default")) return std::nullopt;
    if (d == Direction::Out)
        e.fail("attribute 'default' is for inputs (the value while comm-lost); outputs take 'safe'");
    return e.number("default", 0, -1e300, 1e300);
}

Safe safeOf(Element &e, Direction d, Safe fallback = {}) {
    if (!e.has("safe")) return fallback;
    if (d == Direction::In) e.fail("attribute 'safe' is for outputs; inputs take 'default'");
    const std::string v = e.text("safe");
    if (v == "hold") return Safe{true, 0};
    return Safe{false, e.parseNumber("safe", v, -1e300, 1e300)};
}

Scaling scalingOf(Element &e) {
    Scaling s;
    s.scale = e.number("scale", 1, -1e300, 1e300);
    if (s.scale == 0) e.fail("attribute 'scale' must not be 0");
    s.offset = e.number("offset", 0, -1e300, 1e300);
    return s;
}

std::string pathOf(Element &e, const char *name = "path") {
    std::string p = e.text(name);
    if (p.find_first_of(" \t\r\n") != std::string::npos)
        e.fail(std::string("attribute '") + name + "': a path has no spaces");
    return p;
}

void parseModbusMapping(Element &e, Direction d, DeviceConfig &dev) {
    ModbusMapping m;
    m.direction = d;
    m.line = e.line();
    m.table = e.choice<Table>("table", {{"coil", Table::Coil},
                                        {"discrete", Table::DiscreteInput},
                                        {"holding", Table::HoldingRegister},
                                        {"input", Table::InputRegister}});
    if (d == Direction::Out && (m.table == Table::DiscreteInput || m.table == Table::InputRegister))
        e.fail(std::string("an output writes a coil or a holding register; '") + toString(m.table) + "' is read-only");
    const bool bits = m.table == Table::Coil || m.table == Table::DiscreteInput;
    m.format = e.choice<Format>("type",
                                {{"bool", Format::Bool},
                                 {"u16", Format::U16},
                                 {"uint16", Format::U16},
                                 {"s16", Format::S16},
                                 {"int16", Format::S16},
                                 {"u32", Format::U32},
                                 {"uint32", Format::U32},
                                 {"s32", Format::S32},
                                 {"int32", Format::S32},
                                 {"f32", Format::F32},
                                 {"float", Format::F32},
                                 {"float32", Format::F32}},
                                bits ? Format::Bool : Format::U16);
    if (bits && m.format != Format::Bool) e.fail(std::string("a ") + toString(m.table) + " is one bit: type is bool");
    if (!bits && m.format == Format::Bool) e.fail("a register is 16 bits: type is u16, s16, u32, s32 or f32");
    m.address = static_cast<int>(e.integer("address", -1, 0, 65535));
    if (m.address < 0) e.fail("attribute 'address' is required (0-based protocol address)");
    if (m.address + registerCount(m.format) - 1 > 65535)
        e.fail("a 32-bit value at 65535 would end past the last register");
    m.words = e.choice<WordOrder>("words",
                                  {{"high-first", WordOrder::HighFirst},
                                   {"big", WordOrder::HighFirst},
                                   {"low-first", WordOrder::LowFirst},
                                   {"little", WordOrder::LowFirst}},
                                  WordOrder::HighFirst);
    m.unit = static_cast<int>(e.integer("unit", -1, 0, 255));
    m.path = pathOf(e);
    m.scaling = scalingOf(e);
    m.fallback = fallbackOf(e, d);
    m.safe = safeOf(e, d);
    e.done();
    dev.mappings.push_back(std::move(m));
}

void parseCanFrame(Element &e, DeviceConfig &dev, const std::string &file, std::string_view text) {
    CanFrameMap f;
    f.line = e.line();
    const long long id = e.integer("id", -1, 0, 0x1FFFFFFF);
    if (id < 0) e.fail("attribute 'id' is required (e.g. 0x181)");
    f.id = static_cast<uint32_t>(id);
    f.extended = e.boolean("extended", id > 0x7FF);
    if (!f.extended && id > 0x7FF) e.fail("an 11-bit identifier is at most 0x7FF; set extended=\"true\" for 29 bits");
    f.direction = e.choice<Direction>("direction", {{"in", Direction::In}, {"out", Direction::Out}});
    f.dlc = static_cast<int>(e.integer("dlc", 8, 0, 8));
    e.done();
    std::vector<std::pair<int, int>> used;  // [start, end) of the output frame's signals
    for (pugi::xml_node child : e.node().children()) {
        if (child.type() != pugi::node_element) continue;
        Element s(child, file, text);
        if (std::string_view(child.name()) != "signal") s.fail("expected <signal> inside <frame>");
        CanSignal sig;
        sig.line = s.line();
        sig.start = static_cast<int>(s.integer("start", -1, 0, 63));
        if (sig.start < 0) s.fail("attribute 'start' is required (the least significant bit, 0 = bit 0 of byte 0)");
        sig.length = static_cast<int>(s.integer("length", -1, 1, 64));
        if (sig.length < 0) s.fail("attribute 'length' is required (bits)");
        if (sig.start + sig.length > 64) s.fail("the signal ends past bit 63");
        if (f.direction == Direction::Out && sig.start + sig.length > f.dlc * 8)
            s.fail("the signal ends past the frame's dlc (" + std::to_string(f.dlc) + " bytes)");
        const std::string type = s.has("type") ? s.text("type") : "unsigned";
        if (type == "signed")
            sig.is_signed = true;
        else if (type == "float")
            sig.is_float = true;
        else if (type != "unsigned")
            s.fail("attribute 'type': '" + type + "' is not one of unsigned, signed, float");
        if (sig.is_float && sig.length != 32) s.fail("a float signal is 32 bits long");
        sig.path = pathOf(s);
        sig.scaling = scalingOf(s);
        sig.fallback = fallbackOf(s, f.direction);
        sig.safe = safeOf(s, f.direction);
        s.done();
        if (f.direction == Direction::Out) {
            for (auto [a, b] : used)
                if (sig.start < b && a < sig.start + sig.length)
                    s.fail("the signal overlaps another signal of this output frame");
            used.emplace_back(sig.start, sig.start + sig.length);
        }
        f.signals.push_back(std::move(sig));
    }
    dev.frames.push_back(std::move(f));
}

void parseCia402(Element &e, DeviceConfig &dev) {
    Cia402Node n;
    n.line = e.line();
    n.node = static_cast<int>(e.integer("node", -1, 1, 127));
    if (n.node < 0) e.fail("attribute 'node' is required (1..127)");
    n.scaling = scalingOf(e);
    if (e.has("controlword")) n.controlword = pathOf(e, "controlword");
    if (e.has("target")) n.target = pathOf(e, "target");
    if (e.has("statusword")) n.statusword = pathOf(e, "statusword");
    if (e.has("actual")) n.actual = pathOf(e, "actual");
    if (n.controlword.empty() && n.target.empty() && n.statusword.empty() && n.actual.empty())
        e.fail("map at least one of controlword, target, statusword, actual");
    n.controlword_safe = e.number("controlword_safe", 0, 0, 65535);
    n.target_safe = Safe{true, 0};
    if (e.has("target_safe")) {
        const std::string v = e.text("target_safe");
        n.target_safe = v == "hold" ? Safe{true, 0} : Safe{false, e.parseNumber("target_safe", v, -1e300, 1e300)};
    }
    e.done();
    dev.nodes.push_back(std::move(n));
}

// <drive name= statusword= error_code=/>: the paths must be inputs of the same device (checked
// once the device's mappings are all read).
void parseDrive(Element &e, DeviceConfig &dev) {
    DriveConfig drive;
    drive.line = e.line();
    if (e.has("name")) drive.name = e.text("name");
    drive.statusword = pathOf(e, "statusword");
    if (e.has("error_code")) drive.error_code = pathOf(e, "error_code");
    e.done();
    dev.drives.push_back(std::move(drive));
}

void checkDrives(const DeviceConfig &dev, const std::string &file) {
    std::set<std::string> inputs;
    for (const ModbusMapping &m : dev.mappings)
        if (m.direction == Direction::In) inputs.insert(m.path);
    for (const CanFrameMap &f : dev.frames)
        if (f.direction == Direction::In)
            for (const CanSignal &s : f.signals) inputs.insert(s.path);
    for (const Cia402Node &n : dev.nodes) inputs.insert(n.statusword);
    for (const DriveConfig &d : dev.drives)
        for (const auto &[attribute, path] : {std::pair{"statusword", &d.statusword}, {"error_code", &d.error_code}})
            if (!path->empty() && !inputs.count(*path))
                throw ConfigError(file + ":" + std::to_string(d.line) + ": <drive>: attribute '" + attribute + "': '" +
                                  *path + "' is no input of device '" + dev.name +
                                  "'; name the path of one of its <input>s (or signals)");
}

void checkModbusOverlaps(const DeviceConfig &dev, const std::string &file) {
    // Two outputs must not write the same coil or register of a unit.
    std::map<std::tuple<int, Table, int>, int> written;  // (unit, table, address) -> line
    for (const ModbusMapping &m : dev.mappings) {
        if (m.direction != Direction::Out) continue;
        const int unit = m.unit >= 0 ? m.unit : dev.unit;
        for (int k = 0; k < registerCount(m.format); ++k) {
            auto [it, fresh] = written.emplace(std::make_tuple(unit, m.table, m.address + k), m.line);
            if (!fresh)
                throw ConfigError(file + ":" + std::to_string(m.line) + ": <output>: " + toString(m.table) + " " +
                                  std::to_string(m.address + k) + " of unit " + std::to_string(unit) +
                                  " is already written by the output at line " + std::to_string(it->second));
        }
    }
}

void checkCanIds(const DeviceConfig &dev, const std::string &file) {
    std::map<std::pair<uint32_t, Direction>, int> seen;
    auto add = [&](uint32_t id, Direction d, int line, const char *what) {
        auto [it, fresh] = seen.emplace(std::make_pair(id, d), line);
        if (!fresh) {
            char hex[16];
            std::snprintf(hex, sizeof hex, "0x%X", id);
            throw ConfigError(file + ":" + std::to_string(line) + ": " + what + ": CAN id " + hex + " (" +
                              (d == Direction::In ? "in" : "out") + ") is already used at line " +
                              std::to_string(it->second));
        }
    };
    for (const CanFrameMap &f : dev.frames) add(f.id | (f.extended ? 0x80000000u : 0), f.direction, f.line, "<frame>");
    for (const Cia402Node &n : dev.nodes) {
        if (!n.controlword.empty() || !n.target.empty()) add(0x200u + n.node, Direction::Out, n.line, "<cia402> RPDO1");
        if (!n.statusword.empty() || !n.actual.empty()) add(0x180u + n.node, Direction::In, n.line, "<cia402> TPDO1");
    }
    if (dev.sync) add(0x080, Direction::Out, dev.line, "<device> sync");
}

DeviceConfig parseDevice(Element &e, const std::string &file, std::string_view text) {
    DeviceConfig d;
    d.file = file;
    d.line = e.line();
    d.name = e.text("name");
    d.type = e.choice<DeviceType>("type", {{"modbus-tcp", DeviceType::ModbusTcp},
                                           {"modbus-rtu", DeviceType::ModbusRtu},
                                           {"socketcan", DeviceType::SocketCan}});
    const bool can = d.type == DeviceType::SocketCan;
    d.timeout_ms = e.number("timeout_ms", can ? 100 : 2, 0.01, 60000);
    d.fail_limit = static_cast<int>(e.integer("fail_limit", 1, 1, 1000));
    d.reconnect_ms = e.number("reconnect_ms", 500, 0, 600000);
    d.divider = static_cast<int>(e.integer("divider", 1, 1, 100000));
    switch (d.type) {
    case DeviceType::ModbusTcp: {
        d.host = e.text("host");
        in_addr probe{};
        if (inet_pton(AF_INET, d.host.c_str(), &probe) != 1)
            e.fail("attribute 'host': '" + d.host +
                   "' is not an IPv4 address (libmodbus's modbus_new_tcp takes dotted quads)");
        d.port = static_cast<int>(e.integer("port", 502, 1, 65535));
        d.unit = static_cast<int>(e.integer("unit", 1, 0, 255));
        d.read_gap = static_cast<int>(e.integer("read_gap", 8, 0, 100));
        break;
    }
    case DeviceType::ModbusRtu:
        d.serial = e.text("device");
        d.baud = static_cast<int>(e.integer("baud", 19200, 50, 4000000));
        d.parity = e.choice<char>(
            "parity", {{"N", 'N'}, {"none", 'N'}, {"E", 'E'}, {"even", 'E'}, {"O", 'O'}, {"odd", 'O'}}, 'E');
        d.data_bits = static_cast<int>(e.integer("data_bits", 8, 5, 8));
        d.stop_bits = static_cast<int>(e.integer("stop_bits", 1, 1, 2));
        d.unit = static_cast<int>(e.integer("unit", 1, 1, 247));
        d.read_gap = static_cast<int>(e.integer("read_gap", 8, 0, 100));
        break;
    case DeviceType::SocketCan:
        if (e.has("interface")) d.interface = e.text("interface");
        d.fd = static_cast<int>(e.integer("fd", -1, 0, 1 << 20));
        if (d.interface.empty() == (d.fd < 0))
            e.fail("a socketcan device names either interface=\"can0\" or (tests) fd=\"N\"");
        if (d.interface.size() >= 16)
            e.fail("attribute 'interface': a network interface name is at most 15 characters");
        d.sync = e.boolean("sync", false);
        d.nmt_start = e.boolean("nmt_start", true);
        break;
    }
    e.done();

    for (pugi::xml_node child : e.node().children()) {
        if (child.type() != pugi::node_element) continue;
        Element c(child, file, text);
        const std::string_view tag = child.name();
        if (!can && (tag == "input" || tag == "output"))
            parseModbusMapping(c, tag == "input" ? Direction::In : Direction::Out, d);
        else if (can && tag == "frame")
            parseCanFrame(c, d, file, text);
        else if (can && tag == "cia402")
            parseCia402(c, d);
        else if (tag == "drive")
            parseDrive(c, d);
        else
            c.fail(can ? "a socketcan device holds <frame>, <cia402> and <drive> elements"
                       : "a Modbus device holds <input>, <output> and <drive> elements");
    }
    checkDrives(d, file);
    if (can)
        checkCanIds(d, file);
    else
        checkModbusOverlaps(d, file);
    return d;
}

}  // namespace

IoConfig parseIoConfigText(std::string_view text, const std::string &name) {
    pugi::xml_document doc;
    const pugi::xml_parse_result r = doc.load_buffer(text.data(), text.size());
    if (!r) {
        const auto offset = static_cast<std::size_t>(std::max<std::ptrdiff_t>(0, r.offset));
        const int line =
            1 + static_cast<int>(std::count(
                    text.begin(), text.begin() + static_cast<std::ptrdiff_t>(std::min(offset, text.size())), '\n'));
        throw ConfigError(name + ":" + std::to_string(line) + ": not well-formed XML: " + r.description());
    }
    pugi::xml_node root = doc.document_element();
    Element top(root, name, text);
    if (std::string_view(root.name()) != "ioconfig") top.fail("the top-level element must be <ioconfig>");
    IoConfig config;
    config.file = name;
    if (top.has("status")) config.status = pathOf(top, "status");
    config.budget_us = top.number("budget_us", 0, 0, 10'000'000);
    top.done();
    std::set<std::string> names;
    int drives = 0;
    for (pugi::xml_node child : root.children()) {
        if (child.type() != pugi::node_element) continue;
        Element e(child, name, text);
        if (std::string_view(child.name()) != "device") e.fail("<ioconfig> holds <device> elements");
        DeviceConfig d = parseDevice(e, name, text);
        if (!names.insert(d.name).second) e.fail("a device named '" + d.name + "' is already defined");
        if (config.devices.size() >= kMaxDevices) e.fail("more than " + std::to_string(kMaxDevices) + " devices");
        for (DriveConfig &drive : d.drives) {
            if (drives >= kMaxDrives) e.fail("more than " + std::to_string(kMaxDrives) + " <drive>s");
            drive.index = drives++;
            if (drive.name.empty()) drive.name = "drive " + std::to_string(drive.index);
        }
        config.devices.push_back(std::move(d));
    }
    return config;
}

IoConfig parseIoConfig(const std::string &file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) throw ConfigError(file + ": cannot be read: " + std::strerror(errno));
    std::ostringstream s;
    s << in.rdbuf();
    const std::string text = s.str();
    if (text.size() > (4u << 20)) throw ConfigError(file + ": larger than 4 MiB");
    return parseIoConfigText(text, file);
}

}  // namespace irp::iodispat
