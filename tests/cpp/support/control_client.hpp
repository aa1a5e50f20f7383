// control_client.hpp -- a line-oriented client of irpd's control socket, for the tests.
#pragma once

#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdio>
#include <string>

namespace testing_support {

// A line-oriented client of the control socket.
class Client {
public:
    explicit Client(const std::string &path, int timeout_s = 5) {
        fd_ = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
        connected_ = connect(fd_, reinterpret_cast<sockaddr *>(&addr), sizeof addr) == 0;
        timeval tv{timeout_s, 0};
        setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    }
    ~Client() { close(fd_); }
    bool connected() const { return connected_; }
    void sendRaw(const std::string &bytes) {
        ASSERT_EQ(::write(fd_, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
    }
    // The next line, or "" at end of stream / timeout.
    std::string readLine() {
        for (;;) {
            auto eol = buffer_.find('\n');
            if (eol != std::string::npos) {
                std::string line = buffer_.substr(0, eol);
                buffer_.erase(0, eol + 1);
                return line;
            }
            char chunk[65536];
            ssize_t n = ::read(fd_, chunk, sizeof chunk);
            if (n <= 0) return "";
            buffer_.append(chunk, static_cast<std::size_t>(n));
        }
    }
    nlohmann::json request(const nlohmann::json &req) {
        sendRaw(req.dump() + "\n");
        return nlohmann::json::parse(readLine());
    }

private:
    int fd_ = -1;
    bool connected_ = false;
    std::string buffer_;
};

}  // namespace testing_support
