// control_server.cpp -- the control socket's thread: accept, read lines, answer, all with poll()
// and non-blocking sockets, so that no client can stall the others (or irpd).
#include "control/control_server.hpp"

#include "protocol/errors.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <algorithm>
#include <cstring>
#include <vector>

#ifndef INDUROP_VERSION
#define INDUROP_VERSION "0.0.0"
#endif

namespace irp::control {
namespace {

using json = nlohmann::ordered_json;

struct Client {
    int fd = -1;
    std::string in;        // bytes of the request line being read
    std::string out;       // answers not yet written
    bool closing = false;  // write what is pending, then close
};

std::string line(const json &j) { return j.dump(-1, ' ', false, json::error_handler_t::replace) + "\n"; }

json failure(const json &id, const std::string &code, const std::string &message) {
    return {{"id", id}, {"ok", false}, {"error", {{"code", code}, {"message", message}}}};
}

// How deep arrays and objects nest in a JSON text (strings skipped), without parsing it: a
// request nested thousands deep would be copied and printed by recursion (the id is echoed).
int nestingDepth(const std::string &text) {
    int depth = 0, deepest = 0;
    bool in_string = false;
    for (std::size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (in_string) {
            if (c == '\\')
                ++i;
            else if (c == '"')
                in_string = false;
        } else if (c == '"') {
            in_string = true;
        } else if (c == '[' || c == '{') {
            deepest = std::max(deepest, ++depth);
        } else if (c == ']' || c == '}') {
            --depth;
        }
    }
    return deepest;
}

}  // namespace

std::string answerRequest(const std::string &request, const Handler &handler) {
    json answer;
    json id = nullptr;
    if (nestingDepth(request) > kMaxRequestDepth)
        return line(failure(id, protocol::kBadRequest,
                            "the request nests arrays and objects deeper than " + std::to_string(kMaxRequestDepth) +
                                " levels"));
    try {
        json parsed = json::parse(request);
        if (!parsed.is_object() || !parsed.contains("cmd") || !parsed["cmd"].is_string())
            throw std::invalid_argument("a request is a JSON object with a string \"cmd\"");
        if (parsed.contains("id")) id = parsed["id"];
        auto result = handler(parsed["cmd"].get<std::string>(), parsed);
        answer = result ? json{{"id", id}, {"ok", true}, {"result", std::move(*result)}}
                        : json{{"id", id}, {"ok", false}, {"error", protocol::errorJson(result.error())}};
    } catch (const nlohmann::json::exception &e) {
        answer = failure(id, protocol::kBadRequest, std::string("not valid JSON: ") + e.what());
    } catch (const std::exception &e) {
        answer = failure(id, protocol::kBadRequest, e.what());
    }
    return line(answer);
}

Result<std::unique_ptr<ControlServer>> ControlServer::open(const std::string &path, Handler handler) {
    sockaddr_un addr{};
    if (path.empty() || path.size() >= sizeof addr.sun_path)
        return Error{"--control-socket: '" + path + "' must be a path of 1 to " +
                     std::to_string(sizeof addr.sun_path - 1) + " characters"};
    addr.sun_family = AF_UNIX;
    std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);

    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) return Error{"control socket: " + std::string(std::strerror(errno))};
    int rc = bind(fd, reinterpret_cast<sockaddr *>(&addr), sizeof addr);
    if (rc != 0 && errno == EADDRINUSE) {
        // Left by an irpd that died, or in use?  A live listener accepts a connection.
        int probe = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        bool alive = connect(probe, reinterpret_cast<sockaddr *>(&addr), sizeof addr) == 0;
        close(probe);
        struct stat st {};
        if (alive || (lstat(path.c_str(), &st) == 0 && !S_ISSOCK(st.st_mode))) {
            close(fd);
            return Error{"control socket " + path +
                         (alive ? " is in use by another irpd"
                                : " exists and is not a socket; remove it or choose another path")};
        }
        unlink(path.c_str());
        rc = bind(fd, reinterpret_cast<sockaddr *>(&addr), sizeof addr);
    }
    if (rc != 0) {
        int e = errno;
        close(fd);
        return Error{"control socket " + path + ": " + std::strerror(e)};
    }
    chmod(path.c_str(), 0660);
    if (listen(fd, 16) != 0) {
        int e = errno;
        close(fd);
        unlink(path.c_str());
        return Error{"control socket " + path + ": listen: " + std::strerror(e)};
    }
    std::unique_ptr<ControlServer> server(new ControlServer());
    server->path_ = path;
    server->handler_ = std::move(handler);
    server->listen_fd_ = fd;
    server->wake_fd_ = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    server->thread_ = std::thread([s = server.get()] { s->serve(); });
    return server;
}

ControlServer::~ControlServer() {
    if (wake_fd_ >= 0) {
        uint64_t one = 1;
        (void)!write(wake_fd_, &one, sizeof one);
    }
    if (thread_.joinable()) thread_.join();
    if (listen_fd_ >= 0) close(listen_fd_);
    if (wake_fd_ >= 0) close(wake_fd_);
    if (!path_.empty()) unlink(path_.c_str());
}

/*
 * The control thread: poll() over the listening socket, the stop eventfd and every client.
 * A client sends one JSON object per line and gets one per line back, in order; the first line
 * it receives is the server's hello.  A line over kMaxRequestBytes, or more than
 * kMaxPendingOutput of unread answers, closes that client after an error line.
 */
void ControlServer::serve() {
    std::vector<Client> clients;
    for (;;) {
        std::vector<pollfd> fds;
        fds.push_back({wake_fd_, POLLIN, 0});
        fds.push_back({listen_fd_, POLLIN, 0});
        for (const Client &c : clients)
            fds.push_back({c.fd, static_cast<short>((c.closing ? 0 : POLLIN) | (c.out.empty() ? 0 : POLLOUT)), 0});
        if (poll(fds.data(), fds.size(), -1) < 0 && errno != EINTR) return;
        if (fds[0].revents) break;

        if (fds[1].revents & POLLIN) {
            for (;;) {
                int fd = accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
                if (fd < 0) break;
                if (static_cast<int>(clients.size()) >= kMaxClients) {
                    std::string busy =
                        line(failure(nullptr, protocol::kBusy,
                                     "too many control clients (at most " + std::to_string(kMaxClients) + ")"));
                    (void)!send(fd, busy.data(), busy.size(), MSG_NOSIGNAL);
                    close(fd);
                    continue;
                }
                Client c;
                c.fd = fd;
                c.out =
                    line({{"protocol", protocol::kProtocol}, {"version", kProtocolVersion}, {"irpd", INDUROP_VERSION}});
                clients.push_back(std::move(c));
            }
        }

        for (std::size_t i = 0; i < clients.size(); ++i) {
            Client &c = clients[i];
            const short ev = fds[i + 2].revents;
            if (ev & (POLLIN | POLLHUP | POLLERR)) {
                char buf[8192];
                ssize_t n = ::read(c.fd, buf, sizeof buf);
                if (n <= 0 && !(n < 0 && (errno == EAGAIN || errno == EINTR))) c.closing = true, c.out.clear();
                if (n > 0) c.in.append(buf, static_cast<std::size_t>(n));
                std::size_t eol;
                while (!c.closing && (eol = c.in.find('\n')) != std::string::npos) {
                    std::string request = c.in.substr(0, eol);
                    c.in.erase(0, eol + 1);
                    c.out += answerRequest(request, handler_);
                }
                if (c.in.size() > kMaxRequestBytes) {
                    c.out += line(failure(nullptr, protocol::kTooLarge,
                                          "a request line is at most " + std::to_string(kMaxRequestBytes) + " bytes"));
                    c.in.clear();
                    c.closing = true;
                }
                if (c.out.size() > kMaxPendingOutput) c.closing = true, c.out.clear();  // not reading its answers
            }
            if (!c.out.empty()) {
                ssize_t n = send(c.fd, c.out.data(), c.out.size(), MSG_NOSIGNAL);  // a gone client is no SIGPIPE
                if (n > 0)
                    c.out.erase(0, static_cast<std::size_t>(n));
                else if (n < 0 && errno != EAGAIN && errno != EINTR)
                    c.closing = true, c.out.clear();
            }
        }
        for (std::size_t i = clients.size(); i-- > 0;)
            if (clients[i].closing && clients[i].out.empty()) {
                close(clients[i].fd);
                clients.erase(clients.begin() + static_cast<std::ptrdiff_t>(i));
            }
    }
    // Stopping (irpd stops or restarts): what is still owed goes out if the socket takes it at once
    // (a `restart`'s answer written just before), then every client is closed.
    for (Client &c : clients) {
        if (!c.out.empty()) (void)!send(c.fd, c.out.data(), c.out.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
        close(c.fd);
    }
}

}  // namespace irp::control
