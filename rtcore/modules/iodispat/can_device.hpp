// can_device.hpp -- a SocketCAN device: input frames decoded into variables by a signal map,
// output frames composed from variables and sent every cycle, and the CiA 402 basics over PDOs
// (RPDO1 controlword + target position out, TPDO1 statusword + actual position in, NMT start,
// optional SYNC).  Comm loss: an expected input frame older than timeout_ms, a transmit queue
// full for fail_limit cycles in a row, or a broken socket; outputs then carry their safe values.
#pragma once

#include "can_port.hpp"
#include "device.hpp"

#include <vector>

namespace irp::iodispat {

class CanDevice final : public Device {
public:
    explicit CanDevice(const DeviceConfig &config);
    ~CanDevice() override { stop(); }

    void start(channel::Handle &handle, const VarTable &vars) override;
    void exchange(CycleContext &ctx) noexcept override;
    void stop() noexcept override;

    static constexpr int kMaxFramesPerCycle = 256;  // received frames handled per cycle at most

private:
    struct Signal {
        CanSignal map;  // a copy: the CiA 402 PDOs' signals exist only here
        VarRef var;
    };
    struct RxFrame {
        canid_t key = 0;
        std::vector<Signal> signals;
        int64_t last_ns = 0;  // when it last arrived (long ago until it does)
    };
    struct TxFrame {
        can_frame frame{};
        std::vector<Signal> signals;
    };

    void openPort(CycleContext *ctx) noexcept;
    void sendNmtStart() noexcept;
    void lose(CycleContext &ctx, const char *why) noexcept;
    void applyFallbacks(CycleContext &ctx) noexcept;

    CanPort port_;
    std::vector<RxFrame> rx_;
    std::vector<TxFrame> tx_;
    std::vector<can_filter> filters_;  // the input frames' ids, built once
    int tx_fails_ = 0;
    int64_t next_attempt_ns_ = 0;
};

}  // namespace irp::iodispat
