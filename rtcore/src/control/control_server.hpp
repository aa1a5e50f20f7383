// control_server.hpp -- irpd's control socket: a Unix stream socket served by a non-RT thread of
// its own, speaking the versioned line protocol of docs/control-protocol.md (one JSON object per
// line each way).  It reads only what cannot change under it (the set, its schedule) and the
// shared-memory stats block, which the RT threads update without ever waiting for a reader: a
// client, however slow or hostile, cannot delay a period.
#pragma once

#include <indurop/result.hpp>
#include "protocol/limits.hpp"

#include <nlohmann/json.hpp>

#include <atomic>
#include <functional>
#include <string>
#include <thread>

namespace irp::control {

// The framing's limits, from protocol/control.json (protocol/limits.hpp).
inline constexpr int kProtocolVersion = protocol::kVersion;
inline constexpr auto kMaxRequestBytes = static_cast<std::size_t>(protocol::kMaxRequestBytes);  // one line
inline constexpr auto kMaxPendingOutput =
    static_cast<std::size_t>(protocol::kMaxPendingOutput);  // per client, then it is dropped
inline constexpr auto kMaxClients = static_cast<int>(protocol::kMaxClients);
inline constexpr auto kMaxRequestDepth =
    static_cast<int>(protocol::kMaxRequestDepth);  // arrays and objects inside each other

// Answers one request: the command's result, or an Error (the client gets it as {"ok": false}).
using Handler =
    std::function<Result<nlohmann::ordered_json>(const std::string &command, const nlohmann::json &request)>;

// One request line (without its '\n') -> the answer line (with its '\n'): the JSON is parsed and
// checked for a string "cmd", the handler answers, and anything wrong becomes a bad_request
// answer.  Never throws.  The control thread calls it for every line; the fuzz target
// tests/fuzz/fuzz_control.cpp calls it directly.
std::string answerRequest(const std::string &request, const Handler &handler);

class ControlServer {
public:
    // Binds `path` (mode 0660).  A socket file nobody listens on any more is replaced; one in use
    // by a live irpd is refused.
    static Result<std::unique_ptr<ControlServer>> open(const std::string &path, Handler handler);
    ~ControlServer();  // stops the thread, closes every client, removes the socket file

    const std::string &path() const { return path_; }

private:
    ControlServer() = default;
    void serve();

    std::string path_;
    Handler handler_;
    int listen_fd_ = -1;
    int wake_fd_ = -1;  // eventfd: tells the thread to stop
    std::thread thread_;
};

}  // namespace irp::control
