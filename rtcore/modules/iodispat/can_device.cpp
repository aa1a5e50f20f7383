// can_device.cpp -- SocketCAN devices (see can_device.hpp and docs/io.md).
//
// One exchange, every divider-th cycle:
//   port closed -> reopen (an interface, at most every reconnect_ms); still closed: comm-lost;
//   receive     -> up to kMaxFramesPerCycle waiting frames, each known id decoded into its variables;
//   freshness   -> every expected input frame must have arrived within timeout_ms;
//   transmit    -> every output frame (and RPDO1 per CiA 402 node) from the variables, or from the
//                  safe values while comm-lost; then SYNC if asked.
// All calls are non-blocking socket syscalls; nothing waits.
#include "can_device.hpp"

#include "codec.hpp"

#include <indurop/indurop.h>

#include <cerrno>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace irp::iodispat {

namespace {
constexpr int64_t kNever = std::numeric_limits<int64_t>::min() / 2;  // "arrived" long ago: stale
}

CanDevice::CanDevice(const DeviceConfig &config) : Device(config) {}

void CanDevice::start(channel::Handle &handle, const VarTable &vars) {
    auto where = [&](int line) { return config_.file + ":" + std::to_string(line); };
    for (const CanFrameMap &f : config_.frames) {
        std::vector<Signal> signals;
        for (const CanSignal &s : f.signals) signals.push_back(Signal{s, vars.resolve(handle, s.path, where(s.line))});
        if (f.direction == Direction::In) {
            rx_.push_back(RxFrame{canKey(f.id, f.extended), std::move(signals), 0});
        } else {
            TxFrame t;
            t.frame.can_id = canKey(f.id, f.extended);
            t.frame.can_dlc = static_cast<uint8_t>(f.dlc);
            t.signals = std::move(signals);
            tx_.push_back(std::move(t));
        }
    }
    for (const Cia402Node &n : config_.nodes) {
        // TPDO1 (0x180 + node): statusword u16 at bit 0, actual position s32 at bit 16.
        RxFrame tpdo{canKey(0x180u + static_cast<uint32_t>(n.node), false), {}, 0};
        if (!n.statusword.empty())
            tpdo.signals.push_back(Signal{CanSignal{0, 16, false, false, n.statusword, {}, std::nullopt, {}, n.line},
                                          vars.resolve(handle, n.statusword, where(n.line))});
        if (!n.actual.empty())
            tpdo.signals.push_back(Signal{CanSignal{16, 32, true, false, n.actual, n.scaling, std::nullopt, {}, n.line},
                                          vars.resolve(handle, n.actual, where(n.line))});
        if (!tpdo.signals.empty()) rx_.push_back(std::move(tpdo));
        // RPDO1 (0x200 + node): controlword u16 at bit 0, target position s32 at bit 16.
        TxFrame rpdo;
        rpdo.frame.can_id = canKey(0x200u + static_cast<uint32_t>(n.node), false);
        rpdo.frame.can_dlc = 6;
        if (!n.controlword.empty())
            rpdo.signals.push_back(Signal{
                CanSignal{
                    0, 16, false, false, n.controlword, {}, std::nullopt, Safe{false, n.controlword_safe}, n.line},
                vars.resolve(handle, n.controlword, where(n.line))});
        if (!n.target.empty())
            rpdo.signals.push_back(
                Signal{CanSignal{16, 32, true, false, n.target, n.scaling, std::nullopt, n.target_safe, n.line},
                       vars.resolve(handle, n.target, where(n.line))});
        if (!rpdo.signals.empty()) tx_.push_back(std::move(rpdo));
    }
    std::vector<canid_t> ids;
    for (const RxFrame &r : rx_) ids.push_back(r.key);
    filters_ = CanPort::filtersFor(ids);

    // Output frames start from the variables' values ("hold" before anything was sent).
    for (TxFrame &t : tx_)
        for (const Signal &s : t.signals) {
            double v = 0;
            readVar(handle, s.var, v);
            encodeSignal(t.frame.data, s.map, toRaw(v, s.map.scaling));
        }
    const int64_t now = nowNs();
    for (RxFrame &r : rx_) r.last_ns = kNever;  // missing until it arrives
    CycleContext ctx;
    ctx.handle = &handle;
    applyFallbacks(ctx);
    if (config_.fd >= 0) {
        port_ = CanPort(config_.fd, false);
        sendNmtStart();
    } else {
        if (port_.open(config_.interface.c_str(), filters_) != 0) {
            irp::printf("iodispat: device '%s': %s (retrying every %g ms)", config_.name.c_str(), port_.why(),
                        config_.reconnect_ms);
            next_attempt_ns_ = now + static_cast<int64_t>(config_.reconnect_ms * 1e6);
        } else {
            sendNmtStart();
        }
    }
    comm_lost_ = rx_.empty() ? !port_.isOpen() : true;  // inputs: lost until their frames arrive
}

void CanDevice::stop() noexcept { port_.close(); }

void CanDevice::sendNmtStart() noexcept {
    if (!config_.nmt_start) return;
    for (const Cia402Node &n : config_.nodes) {
        can_frame f{};
        f.can_id = 0x000;
        f.can_dlc = 2;
        f.data[0] = 0x01;  // start remote node
        f.data[1] = static_cast<uint8_t>(n.node);
        if (port_.send(f) != 1) ++errors_;
    }
}

void CanDevice::applyFallbacks(CycleContext &ctx) noexcept {
    for (const RxFrame &r : rx_)
        for (const Signal &s : r.signals)
            if (s.map.fallback) writeVar(*ctx.handle, s.var, *s.map.fallback);
}

void CanDevice::lose(CycleContext &ctx, const char *why) noexcept {
    cause_ = why;
    if (comm_lost_) return;
    comm_lost_ = true;
    irp::printf("iodispat: device '%s' comm lost: %s", config_.name.c_str(), why);
    applyFallbacks(ctx);
}

void CanDevice::exchange(CycleContext &ctx) noexcept {
    const int64_t now = nowNs();
    if (!port_.isOpen()) {
        if (config_.interface.empty() || now < next_attempt_ns_) return lose(ctx, "port closed");
        next_attempt_ns_ = now + static_cast<int64_t>(config_.reconnect_ms * 1e6);
        if (port_.open(config_.interface.c_str(), filters_) != 0) {
            ++errors_;
            return lose(ctx, "cannot reopen the CAN interface");
        }
        for (RxFrame &r : rx_) r.last_ns = kNever;
        sendNmtStart();
    }

    // 1. What arrived.
    bool broken = false;
    can_frame f;
    for (int n = 0; n < kMaxFramesPerCycle; ++n) {
        const int rc = port_.receive(f);
        if (rc == 0) break;
        if (rc < 0) {
            ++errors_;
            if (rc == -EPROTO) continue;  // a frame of another size: skipped
            broken = true;
            break;
        }
        const canid_t key =
            (f.can_id & CAN_EFF_FLAG) ? (f.can_id & (CAN_EFF_FLAG | CAN_EFF_MASK)) : (f.can_id & CAN_SFF_MASK);
        if (f.can_id & (CAN_RTR_FLAG | CAN_ERR_FLAG)) continue;  // remote requests and error frames carry no signals
        for (RxFrame &r : rx_) {
            if (r.key != key) continue;
            uint8_t data[8] = {};
            std::memcpy(data, f.data, f.can_dlc <= 8 ? f.can_dlc : 8);
            for (const Signal &s : r.signals) {
                if (s.map.start + s.map.length > f.can_dlc * 8) {
                    ++errors_;  // shorter than the map says
                    continue;
                }
                writeVar(*ctx.handle, s.var, toVariable(decodeSignal(data, s.map), s.map.scaling));
            }
            r.last_ns = now;
            break;
        }
    }
    if (broken) {
        port_.close();
        next_attempt_ns_ = now + static_cast<int64_t>(config_.reconnect_ms * 1e6);
        return lose(ctx, "the CAN socket failed");
    }

    // 2. Is every expected frame fresh?
    const auto timeout = static_cast<int64_t>(config_.timeout_ms * 1e6);
    bool fresh = true;
    for (const RxFrame &r : rx_) fresh = fresh && now - r.last_ns <= timeout;
    const bool lost = !fresh || tx_fails_ >= config_.fail_limit;
    if (lost) lose(ctx, fresh ? "the transmit queue stays full" : "an input frame is missing");

    // 3. What goes out: the variables, or the safe values while comm-lost.
    bool tx_failed = false;
    for (TxFrame &t : tx_) {
        for (const Signal &s : t.signals) {
            double v;
            if (lost) {
                if (s.map.safe.hold) continue;
                v = s.map.safe.value;
            } else if (!readVar(*ctx.handle, s.var, v)) {
                continue;
            }
            encodeSignal(t.frame.data, s.map, toRaw(v, s.map.scaling));
        }
        const int rc = port_.send(t.frame);
        if (rc == 0)
            tx_failed = true, ++errors_;
        else if (rc < 0)
            broken = true, ++errors_;
        if (broken) break;
    }
    if (!broken && config_.sync) {
        can_frame sync{};
        sync.can_id = 0x080;
        sync.can_dlc = 0;
        const int rc = port_.send(sync);
        if (rc == 0)
            tx_failed = true, ++errors_;
        else if (rc < 0)
            broken = true, ++errors_;
    }
    if (broken) {
        port_.close();
        next_attempt_ns_ = now + static_cast<int64_t>(config_.reconnect_ms * 1e6);
        return lose(ctx, "the CAN socket failed");
    }
    tx_fails_ = tx_failed ? tx_fails_ + 1 : 0;
    if (!lost && tx_fails_ < config_.fail_limit) {
        if (comm_lost_) irp::printf("iodispat: device '%s' answers", config_.name.c_str());
        comm_lost_ = false;
        ++rounds_;
    } else if (tx_fails_ >= config_.fail_limit) {
        lose(ctx, "the transmit queue stays full");
    }
}

}  // namespace irp::iodispat
