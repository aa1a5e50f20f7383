// process_output.hpp -- a process module's stdout and stderr turned into irpd's log lines, within
// limits: each line becomes "[name] line"; lines longer than max_line_bytes are cut; more than
// lines_per_second lines or bytes_per_second bytes in one second are dropped and counted, and one
// line per second says how many.  Memory is bounded (a partial line per stream), and so is the
// work of one read() (read_bytes_per_poll per stream).
//
// Used from one thread (the process supervisor's); never throws from a sink that throws.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

namespace irp::hosts {

// Limits on what a child may send to irpd's log.
struct OutputLimits {
    uint32_t lines_per_second = 200;
    uint32_t bytes_per_second = 64 * 1024;
    uint32_t max_line_bytes = 4096;
    uint32_t read_bytes_per_poll = 256 * 1024;  // per stream: bounds irpd's work per poll()
};

class ProcessOutput {
public:
    using Sink = std::function<void(std::string_view line)>;  // one line, no newline
    using Now = std::function<int64_t()>;                     // CLOCK_MONOTONIC ns (tests: a fake)

    // name: the module's, for "[name] " and the drop report.  now: the rate window's clock.
    ProcessOutput(std::string name, OutputLimits limits, Sink sink, Now now = {});
    ~ProcessOutput();  // closes the pipes
    ProcessOutput(const ProcessOutput &) = delete;
    ProcessOutput &operator=(const ProcessOutput &) = delete;

    // The read ends of a new run's stdout and stderr (owned from now on; -1 = none).  The partial
    // lines of the run before are forgotten; the counts go on.
    void attach(int out_fd, int err_fd);
    // Forwards what the pipes hold now.  final_drain: after the child ended, up to 1 MiB per stream
    // (its last words) instead of read_bytes_per_poll.
    void read(bool final_drain = false);
    // A last line without newline is forwarded, the pipes are closed.
    void close();
    // Says how many lines the rate limit dropped in the window, once the window (1 s) ended or at
    // once when `force`; a new window begins.
    void reportDrops(bool force);
    bool dropping() const { return window_dropped_ > 0; }

    uint64_t lines() const { return lines_; }                 // forwarded
    uint64_t droppedLines() const { return dropped_lines_; }  // dropped by the rate limit

private:
    struct Stream {
        int fd = -1;
        std::string partial;    // an unfinished line, at most max_line_bytes
        bool skipping = false;  // the current line was cut: skip up to its newline
    };
    void readStream(Stream &stream, bool final_drain);
    void deliver(std::string_view line, bool cut);
    void emit(std::string_view line);

    std::string name_;
    OutputLimits limits_;
    Sink sink_;
    Now now_;
    Stream out_, err_;
    uint64_t lines_ = 0, dropped_lines_ = 0;
    // the rate window
    int64_t window_start_ns_ = 0;
    uint64_t window_lines_ = 0, window_bytes_ = 0;
    uint64_t window_dropped_ = 0, window_dropped_bytes_ = 0;
};

}  // namespace irp::hosts
