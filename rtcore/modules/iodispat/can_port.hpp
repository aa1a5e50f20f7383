// can_port.hpp -- a CAN port that moves whole struct can_frame messages without blocking:
// SocketCAN (socket(PF_CAN, SOCK_RAW, CAN_RAW) bound to an interface) or, for tests on machines
// without CAN, any descriptor carrying one can_frame per message (a socketpair(AF_UNIX,
// SOCK_SEQPACKET) end).
#pragma once

#include <linux/can.h>

#include <cstdint>
#include <string>
#include <vector>

namespace irp::iodispat {

class CanPort {
public:
    CanPort() = default;
    // Adopts fd (a SocketCAN socket or a SOCK_SEQPACKET end); made non-blocking.  owned: close it at the end.
    explicit CanPort(int fd, bool owned = false);
    ~CanPort() { close(); }
    CanPort(CanPort &&other) noexcept;
    CanPort &operator=(CanPort &&other) noexcept;
    CanPort(const CanPort &) = delete;
    CanPort &operator=(const CanPort &) = delete;

    // The receive filters that let exactly these ids through (CAN_EFF_FLAG set for 29-bit ids).
    static std::vector<can_filter> filtersFor(const std::vector<canid_t> &ids);

    // Opens a CAN_RAW socket on `interface` (e.g. "can0", "vcan0") that receives only what
    // `filters` let through (none: nothing).  0, or -errno and why() says what failed (e.g.
    // "socket(PF_CAN, SOCK_RAW, CAN_RAW): Address family not supported by protocol" where the
    // kernel has no CAN).  No allocation: a reconnect may call it from run().
    int open(const char *interface, const std::vector<can_filter> &filters) noexcept;
    const char *why() const { return why_; }

    bool isOpen() const { return fd_ >= 0; }
    int fd() const { return fd_; }

    // 1: sent; 0: the transmit queue is full (EAGAIN, ENOBUFS); -errno: the port is broken.
    int send(const can_frame &frame) noexcept;
    // 1: a frame in `frame`; 0: none waiting; -errno: the port is broken (-EPIPE: the peer closed).
    int receive(can_frame &frame) noexcept;
    void close() noexcept;

private:
    int fd_ = -1;
    bool owned_ = false;
    char why_[160] = "";
};

// A frame's identifier as the port reports it: CAN_EFF_FLAG | id for 29-bit ids.
inline canid_t canKey(uint32_t id, bool extended) {
    return extended ? (id & CAN_EFF_MASK) | CAN_EFF_FLAG : id & CAN_SFF_MASK;
}

}  // namespace irp::iodispat
