// modbus_device.cpp -- Modbus TCP/RTU devices (see modbus_device.hpp and docs/io.md).
//
// One round, every divider-th cycle:
//   not connected  -> a connect attempt when due (else nothing): the first cycle tries at once
//                     (start()'s attempt comes before irpd starts the set's processes, such as a
//                     drive simulator), then 10 ms later, 20, 40... up to every reconnect_ms; a
//                     round that succeeds starts the sequence over;
//   first connect  -> read the output blocks once, so that "hold" keeps the device's own values;
//   every round    -> read each input block, write the variables; read the variables, write
//                     each output block (the safe values while comm-lost, and in the first round
//                     after the device answers again).
// Every wait is one libmodbus call with its response timeout set to min(timeout_ms, what is left
// of the cycle's budget); the first failure ends the round.  A timeout counts towards fail_limit;
// a broken connection (reset, refused, closed) or a failure while comm-lost is comm loss at once.
// A request that timed out is still owed an answer: the next round first reads it (and drops it),
// waiting as for a transaction, and sends nothing new until it came.  Sending first would take the
// late answer for the new request's (libmodbus: "Invalid data") and owe one more: one stall of the
// device then failed three rounds in a row (docs/io-load.md).
// libmodbus allocates nothing after modbus_new_*; these calls are socket or tty syscalls.
#include "modbus_device.hpp"

#include "codec.hpp"

#include <indurop/indurop.h>

#include <algorithm>
#include <cerrno>
#include <map>
#include <stdexcept>
#include <tuple>

namespace irp::iodispat {

namespace {

constexpr int64_t kMinSliceNs = 100'000;       // a transaction is not started with less time than this left
constexpr int64_t kFirstRetryNs = 10'000'000;  // the first reconnect attempt's wait (then doubling up to reconnect_ms)

int maxCount(Table t, bool write) {
    const bool bits = t == Table::Coil || t == Table::DiscreteInput;
    if (bits) return write ? MODBUS_MAX_WRITE_BITS : MODBUS_MAX_READ_BITS;
    return write ? MODBUS_MAX_WRITE_REGISTERS : MODBUS_MAX_READ_REGISTERS;
}

bool isBits(Table t) { return t == Table::Coil || t == Table::DiscreteInput; }

// The device answered with a Modbus exception (it is there, but refused this request).
bool isException(int e) { return e > MODBUS_ENOBASE && e <= MODBUS_ENOBASE + MODBUS_EXCEPTION_GATEWAY_TARGET; }

// The connection itself is gone: no use waiting for fail_limit.
bool isBroken(int e) {
    switch (e) {
    case ECONNRESET:
    case ECONNREFUSED:
    case ECONNABORTED:
    case EPIPE:
    case ENOTCONN:
    case EBADF:
    case EHOSTUNREACH:
    case ENETUNREACH:
    case ENETDOWN:
    case EIO:
    case ENODEV:
    case ENXIO:
    case ENOENT: return true;
    default: return false;
    }
}

}  // namespace

ModbusDevice::ModbusDevice(const DeviceConfig &config) : Device(config) {}

ModbusDevice::~ModbusDevice() { stop(); }

std::vector<ModbusDevice::Block> ModbusDevice::group(Direction direction, const VarTable &vars,
                                                     channel::Handle &handle) const {
    // (unit, table) -> its mappings by address
    std::map<std::pair<int, Table>, std::vector<const ModbusMapping *>> by;
    for (const ModbusMapping &m : config_.mappings)
        if (m.direction == direction) by[{m.unit >= 0 ? m.unit : config_.unit, m.table}].push_back(&m);
    std::vector<Block> blocks;
    const bool write = direction == Direction::Out;
    for (auto &[key, list] : by) {
        std::stable_sort(list.begin(), list.end(), [](auto *a, auto *b) { return a->address < b->address; });
        Block *b = nullptr;
        for (const ModbusMapping *m : list) {
            const int n = registerCount(m->format);
            const int end = b ? b->start + b->count : 0;
            // Reads may span a few unmapped registers; writes only consecutive ones (a gap would overwrite them).
            const int gap = isBits(key.second) ? config_.read_gap * 16 : config_.read_gap;
            const bool joins = b && (write ? m->address == end : m->address <= end + gap) &&
                               std::max(end, m->address + n) - b->start <= maxCount(key.second, write);
            if (!joins) {
                blocks.push_back(Block{});
                b = &blocks.back();
                b->unit = key.first;
                b->table = key.second;
                b->start = m->address;
                b->count = 0;
            }
            b->count = std::max(b->count, m->address + n - b->start);
            const std::string where = config_.file + ":" + std::to_string(m->line);
            b->items.push_back(Item{m->address - b->start, m, vars.resolve(handle, m->path, where)});
        }
    }
    for (Block &b : blocks) {
        if (isBits(b.table))
            b.bits.assign(static_cast<std::size_t>(b.count), 0);
        else
            b.regs.assign(static_cast<std::size_t>(b.count), 0);
    }
    return blocks;
}

void ModbusDevice::start(channel::Handle &handle, const VarTable &vars) {
    inputs_ = group(Direction::In, vars, handle);
    outputs_ = group(Direction::Out, vars, handle);
    if (config_.type == DeviceType::ModbusTcp)
        mb_ = modbus_new_tcp(config_.host.c_str(), config_.port);
    else
        mb_ =
            modbus_new_rtu(config_.serial.c_str(), config_.baud, config_.parity, config_.data_bits, config_.stop_bits);
    if (!mb_)
        throw std::runtime_error("device '" + config_.name +
                                 "': libmodbus refused its parameters: " + modbus_strerror(errno));
    modbus_set_slave(mb_, config_.unit);
    modbus_set_error_recovery(mb_, MODBUS_ERROR_RECOVERY_NONE);
    // The output blocks start from the variables' values (used for "hold" until the device's own are read).
    CycleContext ctx;
    ctx.handle = &handle;
    for (Block &b : outputs_) compose(ctx, b, false);
    applyFallbacks(ctx);  // comm-lost until the first round
    // One connect attempt now; the first exchange happens in run().  A refusal here does not
    // delay the first cycle's attempt: irpd starts the set's processes (a drive simulator, a
    // gateway) after the thread modules' start(), so a peer of the set cannot listen yet.
    retry_ns_ = std::min(kFirstRetryNs, reconnectNs());
    ctx.start_ns = nowNs();
    if (arm(ctx) && modbus_connect(mb_) == 0) {
        connected_ = true;
    } else {
        cause_ = modbus_strerror(errno);
        next_attempt_ns_ = 0;
    }
}

int64_t ModbusDevice::reconnectNs() const noexcept { return static_cast<int64_t>(config_.reconnect_ms * 1e6); }

void ModbusDevice::scheduleReconnect() noexcept {
    next_attempt_ns_ = nowNs() + retry_ns_;
    retry_ns_ = std::min(2 * retry_ns_, reconnectNs());
}

void ModbusDevice::stop() noexcept {
    if (mb_) {
        modbus_close(mb_);
        modbus_free(mb_);
        mb_ = nullptr;
    }
    connected_ = false;
}

bool ModbusDevice::arm(CycleContext &ctx) noexcept {
    int64_t wait = static_cast<int64_t>(config_.timeout_ms * 1e6);
    if (ctx.deadline_ns != kNoDeadline) {
        const int64_t left = ctx.deadline_ns - nowNs();
        if (left < kMinSliceNs) return false;
        wait = std::min(wait, left);
    }
    const auto us = static_cast<uint32_t>(std::max<int64_t>(1, wait / 1000));
    modbus_set_response_timeout(mb_, us / 1'000'000, us % 1'000'000);
    modbus_set_byte_timeout(mb_, us / 1'000'000, us % 1'000'000);
    return true;
}

void ModbusDevice::compose(CycleContext &ctx, Block &b, bool safe) noexcept {
    for (const Item &it : b.items) {
        const ModbusMapping &m = *it.mapping;
        double v;
        if (safe) {
            if (m.safe.hold) continue;  // the block keeps what was sent last
            v = m.safe.value;
        } else if (!readVar(*ctx.handle, it.var, v)) {
            continue;  // cannot happen for a resolved path; keep the last value
        }
        const double raw = toRaw(v, m.scaling);
        if (isBits(b.table))
            b.bits[static_cast<std::size_t>(it.offset)] = raw != 0 && raw == raw ? 1 : 0;
        else
            encodeRegisters(raw, m.format, m.words, &b.regs[static_cast<std::size_t>(it.offset)]);
    }
}

ModbusDevice::Outcome ModbusDevice::transact(CycleContext &ctx, Block &b, bool write, bool &answered) noexcept {
    answered = false;
    if (!arm(ctx)) return Outcome::Skipped;
    modbus_set_slave(mb_, b.unit);
    int rc = -1;
    if (write) {
        rc = b.table == Table::Coil ? modbus_write_bits(mb_, b.start, b.count, b.bits.data())
                                    : modbus_write_registers(mb_, b.start, b.count, b.regs.data());
    } else {
        switch (b.table) {
        case Table::Coil: rc = modbus_read_bits(mb_, b.start, b.count, b.bits.data()); break;
        case Table::DiscreteInput: rc = modbus_read_input_bits(mb_, b.start, b.count, b.bits.data()); break;
        case Table::HoldingRegister: rc = modbus_read_registers(mb_, b.start, b.count, b.regs.data()); break;
        case Table::InputRegister: rc = modbus_read_input_registers(mb_, b.start, b.count, b.regs.data()); break;
        }
    }
    if (rc == b.count) return Outcome::Ok;
    const int e = rc < 0 ? errno : EMBBADDATA;
    if (e == ETIMEDOUT) answer_owed_ = true;
    if (isException(e)) {
        // The device is there but refuses this block (a wrong address in ioconfig.xml?): an error,
        // not comm loss; the rest of the round goes on.
        ++errors_;
        answered = true;
        if (!b.reported) {
            b.reported = true;
            irp::printf("iodispat: device '%s': %s %s %d..%d of unit %d: %s", config_.name.c_str(),
                        write ? "writing" : "reading", toString(b.table), b.start, b.start + b.count - 1, b.unit,
                        modbus_strerror(e));
        }
        return Outcome::Ok;
    }
    errno = e;
    return Outcome::Failed;
}

ModbusDevice::Outcome ModbusDevice::collectOwedAnswer(CycleContext &ctx) noexcept {
    if (!arm(ctx)) return Outcome::Skipped;
    uint8_t late[MODBUS_MAX_ADU_LENGTH];
    if (modbus_receive_confirmation(mb_, late) < 0) return Outcome::Failed;  // still silent: errno says how
    answer_owed_ = false;
    return Outcome::Ok;
}

void ModbusDevice::applyFallbacks(CycleContext &ctx) noexcept {
    for (Block &b : inputs_)
        for (const Item &it : b.items)
            if (it.mapping->fallback) writeVar(*ctx.handle, it.var, *it.mapping->fallback);
}

ModbusDevice::Outcome ModbusDevice::round(CycleContext &ctx) noexcept {
    bool answered;
    if (!outputs_known_) {
        // "hold" must keep what the device has: read the written registers and coils once.
        for (Block &b : outputs_) {
            if (b.table == Table::HoldingRegister || b.table == Table::Coil) {
                Outcome o = transact(ctx, b, false, answered);
                if (o != Outcome::Ok) return o;
            }
        }
        outputs_known_ = true;
    }
    for (Block &b : inputs_) {
        Outcome o = transact(ctx, b, false, answered);
        if (o != Outcome::Ok) return o;
        if (answered) continue;  // an exception: no values
        for (const Item &it : b.items) {
            const std::size_t at = static_cast<std::size_t>(it.offset);
            const double raw = isBits(b.table) ? (b.bits[at] ? 1.0 : 0.0)
                                               : decodeRegisters(&b.regs[at], it.mapping->format, it.mapping->words);
            writeVar(*ctx.handle, it.var, toVariable(raw, it.mapping->scaling));
        }
    }
    for (Block &b : outputs_) {
        compose(ctx, b, comm_lost_);
        Outcome o = transact(ctx, b, true, answered);
        if (o != Outcome::Ok) return o;
    }
    return Outcome::Ok;
}

void ModbusDevice::fail(CycleContext &ctx, int error) noexcept {
    cause_ = modbus_strerror(error);
    ++errors_;
    ++fails_;
    dirty_ = true;
    if (isBroken(error) || comm_lost_ || fails_ >= config_.fail_limit) {
        if (!comm_lost_) {
            irp::printf("iodispat: device '%s' comm lost: %s", config_.name.c_str(), modbus_strerror(error));
            comm_lost_ = true;
            applyFallbacks(ctx);
        }
        modbus_close(mb_);
        connected_ = false;
        scheduleReconnect();
    }
}

void ModbusDevice::exchange(CycleContext &ctx) noexcept {
    if (!mb_) return;
    if (!connected_) {
        if (nowNs() < next_attempt_ns_) return;
        if (!arm(ctx)) {
            ++skipped_;
            return;
        }
        if (modbus_connect(mb_) != 0) {
            cause_ = modbus_strerror(errno);
            scheduleReconnect();
            ++errors_;
            if (!comm_lost_) {
                comm_lost_ = true;
                applyFallbacks(ctx);
            }
            return;
        }
        connected_ = true;
        dirty_ = false;
        answer_owed_ = false;  // a new connection owes nothing
    }
    if (answer_owed_) {
        switch (collectOwedAnswer(ctx)) {
        case Outcome::Ok: break;
        case Outcome::Skipped: ++skipped_; return;
        case Outcome::Failed: fail(ctx, errno); return;
        }
    }
    if (dirty_) {
        modbus_flush(mb_);  // what else a failed transaction left: a partial or malformed answer
        dirty_ = false;
    }
    switch (round(ctx)) {
    case Outcome::Ok:
        fails_ = 0;
        ++rounds_;
        retry_ns_ = std::min(kFirstRetryNs, reconnectNs());  // a later loss retries soon again
        if (comm_lost_) {
            comm_lost_ = false;  // this round sent the safe values; the next sends the variables'
            irp::printf("iodispat: device '%s' answers", config_.name.c_str());
        }
        break;
    case Outcome::Skipped: ++skipped_; break;
    case Outcome::Failed: fail(ctx, errno); break;
    }
}

}  // namespace irp::iodispat
