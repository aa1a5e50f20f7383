// can_port.cpp -- SocketCAN raw sockets and the socketpair stand-in (see can_port.hpp).
#include "can_port.hpp"

#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace irp::iodispat {

CanPort::CanPort(int fd, bool owned) : fd_(fd), owned_(owned) {
    if (fd_ >= 0) {
        const int flags = fcntl(fd_, F_GETFL);
        if (flags >= 0) fcntl(fd_, F_SETFL, flags | O_NONBLOCK);
    }
}

CanPort::CanPort(CanPort &&other) noexcept : fd_(other.fd_), owned_(other.owned_) { other.fd_ = -1; }

CanPort &CanPort::operator=(CanPort &&other) noexcept {
    if (this != &other) {
        close();
        fd_ = other.fd_;
        owned_ = other.owned_;
        other.fd_ = -1;
    }
    return *this;
}

std::vector<can_filter> CanPort::filtersFor(const std::vector<canid_t> &ids) {
    std::vector<can_filter> filters;
    for (canid_t id : ids)
        filters.push_back(
            can_filter{id, (id & CAN_EFF_FLAG) ? (CAN_EFF_FLAG | CAN_EFF_MASK) : (CAN_EFF_FLAG | CAN_SFF_MASK)});
    return filters;
}

int CanPort::open(const char *interface, const std::vector<can_filter> &filters) noexcept {
    close();
    auto failed = [&](int s, const char *what) {
        const int e = errno;
        if (s >= 0) ::close(s);
        std::snprintf(why_, sizeof why_, "%s '%s': %s", what, interface, std::strerror(e));
        return -e;
    };
    const int s = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
    if (s < 0) {
        const int e = errno;
        std::snprintf(why_, sizeof why_, "socket(PF_CAN, SOCK_RAW, CAN_RAW): %s", std::strerror(e));
        return -e;
    }
    ifreq ifr{};
    std::strncpy(ifr.ifr_name, interface, IFNAMSIZ - 1);
    if (::ioctl(s, SIOCGIFINDEX, &ifr) < 0) return failed(s, "CAN interface");
    if (::setsockopt(s, SOL_CAN_RAW, CAN_RAW_FILTER, filters.empty() ? nullptr : filters.data(),
                     static_cast<socklen_t>(filters.size() * sizeof(can_filter))) < 0)
        return failed(s, "setsockopt(CAN_RAW_FILTER) on");
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    addr.can_ifindex = ifr.ifr_ifindex;
    if (::bind(s, reinterpret_cast<sockaddr *>(&addr), sizeof addr) < 0) return failed(s, "bind to CAN interface");
    fd_ = s;
    owned_ = true;
    why_[0] = '\0';
    return 0;
}

int CanPort::send(const can_frame &frame) noexcept {
    if (fd_ < 0) return -EBADF;
    const ssize_t n = ::send(fd_, &frame, sizeof frame, MSG_DONTWAIT | MSG_NOSIGNAL);
    if (n == static_cast<ssize_t>(sizeof frame)) return 1;
    if (n >= 0) return -EPROTO;
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS || errno == EINTR) return 0;
    return -errno;
}

int CanPort::receive(can_frame &frame) noexcept {
    if (fd_ < 0) return -EBADF;
    const ssize_t n = ::recv(fd_, &frame, sizeof frame, MSG_DONTWAIT);
    if (n == static_cast<ssize_t>(sizeof frame)) return 1;
    if (n == 0) return -EPIPE;  // a stream or seqpacket peer closed
    if (n > 0) return -EPROTO;  // not a classic CAN frame (a CAN FD frame, or garbage on the test descriptor)
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return 0;
    return -errno;
}

void CanPort::close() noexcept {
    if (fd_ >= 0 && owned_) ::close(fd_);
    fd_ = -1;
}

}  // namespace irp::iodispat
