// modbus_device.hpp -- a Modbus TCP or RTU device through libmodbus: its mappings grouped into
// blocks of consecutive addresses (one transaction each), read and written once per cycle with
// a short response timeout; comm loss, safe outputs and reconnects at growing intervals (10 ms,
// doubling up to reconnect_ms).
#pragma once

#include "device.hpp"

#include <modbus.h>

#include <vector>

namespace irp::iodispat {

class ModbusDevice final : public Device {
public:
    explicit ModbusDevice(const DeviceConfig &config);
    ~ModbusDevice() override;

    void start(channel::Handle &handle, const VarTable &vars) override;
    void exchange(CycleContext &ctx) noexcept override;
    void stop() noexcept override;

    // The transactions one round makes (for tests and the docs' claims).
    std::size_t inputBlocks() const { return inputs_.size(); }
    std::size_t outputBlocks() const { return outputs_.size(); }

private:
    struct Item {
        int offset = 0;  // registers (or bits) from the block's start
        const ModbusMapping *mapping = nullptr;
        VarRef var;
    };
    struct Block {
        int unit = 1;
        Table table = Table::HoldingRegister;
        int start = 0;
        int count = 0;
        std::vector<Item> items;
        std::vector<uint16_t> regs;  // registers: the last read or sent values
        std::vector<uint8_t> bits;   // coils / discrete inputs
        bool reported = false;       // an exception response was logged once
    };
    enum class Outcome { Ok, Failed, Skipped };

    std::vector<Block> group(Direction direction, const VarTable &vars, channel::Handle &handle) const;
    bool arm(CycleContext &ctx) noexcept;  // sets the timeout; false: no time left
    Outcome collectOwedAnswer(CycleContext &ctx) noexcept;
    Outcome transact(CycleContext &ctx, Block &b, bool write, bool &answered) noexcept;
    Outcome round(CycleContext &ctx) noexcept;
    void fail(CycleContext &ctx, int error) noexcept;
    void applyFallbacks(CycleContext &ctx) noexcept;
    void compose(CycleContext &ctx, Block &b, bool safe) noexcept;
    int64_t reconnectNs() const noexcept;
    void scheduleReconnect() noexcept;  // the next attempt after retry_ns_, which then doubles

    modbus_t *mb_ = nullptr;
    std::vector<Block> inputs_, outputs_;
    bool connected_ = false;
    bool dirty_ = false;           // a transaction failed: flush stale bytes before the next
    bool answer_owed_ = false;     // a request timed out: its answer may still come (read before the next)
    bool outputs_known_ = false;   // the output blocks hold the device's values (read once at the first connect)
    int fails_ = 0;                // failed rounds in a row
    int64_t next_attempt_ns_ = 0;  // no connect attempt before this
    int64_t retry_ns_ = 0;         // the wait before the next attempt after this one fails
};

}  // namespace irp::iodispat
