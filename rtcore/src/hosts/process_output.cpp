// process_output.cpp -- splitting a child's output into lines, cutting and rate-limiting them;
// see process_output.hpp.
#include "hosts/process_output.hpp"

#include "osal/clock.hpp"

#include <unistd.h>

#include <algorithm>
#include <cerrno>

namespace irp::hosts {
namespace {
constexpr int64_t kSecond = 1'000'000'000;
constexpr uint32_t kFinalDrainBytes = 1u << 20;  // what is read after an exit at most
}  // namespace

ProcessOutput::ProcessOutput(std::string name, OutputLimits limits, Sink sink, Now now)
    : name_(std::move(name)), limits_(limits), sink_(std::move(sink)), now_(std::move(now)) {
    if (!now_) now_ = [] { return osal::monotonicNow(); };
}

ProcessOutput::~ProcessOutput() {
    for (Stream *s : {&out_, &err_})
        if (s->fd >= 0) ::close(s->fd);
}

void ProcessOutput::emit(std::string_view line) {
    try {
        if (sink_) sink_(line);
    } catch (...) {
        // a sink that throws loses the line, never the process's supervision
    }
}

void ProcessOutput::attach(int out_fd, int err_fd) {
    for (Stream *s : {&out_, &err_}) {
        if (s->fd >= 0) ::close(s->fd);
        s->partial.clear();
        s->skipping = false;
    }
    out_.fd = out_fd;
    err_.fd = err_fd;
}

void ProcessOutput::reportDrops(bool force) {
    const int64_t t = now_();
    if (!force && t - window_start_ns_ < kSecond) return;
    if (window_dropped_) {
        emit("irpd: process module '" + name_ + "': " + std::to_string(window_dropped_) + " output lines (" +
             std::to_string(window_dropped_bytes_) + " bytes) dropped: more than " +
             std::to_string(limits_.lines_per_second) + " lines or " + std::to_string(limits_.bytes_per_second / 1024) +
             " KiB per second");
    }
    window_start_ns_ = t;
    window_lines_ = window_bytes_ = 0;
    window_dropped_ = window_dropped_bytes_ = 0;
}

void ProcessOutput::deliver(std::string_view line, bool cut) {
    if (now_() - window_start_ns_ >= kSecond) reportDrops(true);
    if (window_lines_ >= limits_.lines_per_second || window_bytes_ + line.size() > limits_.bytes_per_second) {
        ++window_dropped_;
        window_dropped_bytes_ += line.size();
        ++dropped_lines_;
        return;
    }
    ++window_lines_;
    window_bytes_ += line.size();
    ++lines_;
    std::string text;
    text.reserve(name_.size() + line.size() + 32);
    text.append("[").append(name_).append("] ").append(line);
    if (cut) text.append(" [line cut at ").append(std::to_string(limits_.max_line_bytes)).append(" bytes]");
    emit(text);
}

void ProcessOutput::readStream(Stream &stream, bool final_drain) {
    if (stream.fd < 0) return;
    char buffer[16384];
    uint64_t budget = final_drain ? kFinalDrainBytes : limits_.read_bytes_per_poll;
    const std::size_t max_line = std::max<uint32_t>(limits_.max_line_bytes, 1);
    while (budget > 0) {
        const ssize_t n = ::read(stream.fd, buffer, std::min<uint64_t>(sizeof buffer, budget));
        if (n < 0 && errno == EINTR) continue;
        if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK)) {  // EOF or a dead pipe
            ::close(stream.fd);
            stream.fd = -1;
            break;
        }
        if (n < 0) break;  // nothing more for now
        budget -= static_cast<uint64_t>(n);
        std::string_view data(buffer, static_cast<std::size_t>(n));
        while (!data.empty()) {
            const std::size_t nl = data.find('\n');
            const std::size_t take = nl == std::string_view::npos ? data.size() : nl;
            if (stream.skipping) {
                if (nl == std::string_view::npos) break;
                stream.skipping = false;
                data.remove_prefix(nl + 1);
                continue;
            }
            const std::size_t room = max_line - stream.partial.size();
            if (take > room) {
                stream.partial.append(data.substr(0, room));
                deliver(stream.partial, true);
                stream.partial.clear();
                if (nl == std::string_view::npos) {
                    stream.skipping = true;
                    break;
                }
                data.remove_prefix(nl + 1);
                continue;
            }
            if (nl == std::string_view::npos) {
                stream.partial.append(data);
                break;
            }
            if (stream.partial.empty()) {
                deliver(data.substr(0, nl), false);
            } else {
                stream.partial.append(data.substr(0, nl));
                deliver(stream.partial, false);
                stream.partial.clear();
            }
            data.remove_prefix(nl + 1);
        }
    }
}

void ProcessOutput::read(bool final_drain) {
    readStream(out_, final_drain);
    readStream(err_, final_drain);
}

void ProcessOutput::close() {
    for (Stream *s : {&out_, &err_}) {
        if (!s->partial.empty()) deliver(s->partial, false);  // a last line without newline
        s->partial.clear();
        s->skipping = false;
        if (s->fd >= 0) ::close(s->fd);
        s->fd = -1;
    }
}

}  // namespace irp::hosts
