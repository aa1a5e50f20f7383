// indurop.cpp -- libindurop's runtime services for modules: irp::printf, irp::cycle() and
// irp::runAbortRequested().
//
// irp::printf must be callable from the RT thread, so it never takes a lock, allocates or makes a
// syscall: it formats into a cell of a bounded multi-producer ring (D. Vyukov's bounded queue:
// each cell carries a sequence number that tells producers and the consumer whose turn it is).
#include "runtime.hpp"

#include <array>
#include <atomic>
#include <cstdarg>
#include <cstdio>

namespace irp {
namespace {

struct alignas(64) LogCell {
    std::atomic<std::size_t> sequence;
    uint32_t length;
    char text[runtime::kLogLineBytes];
};

struct LogRing {
    std::array<LogCell, runtime::kLogLines> cells;
    alignas(64) std::atomic<std::size_t> enqueue_pos{0};
    alignas(64) std::atomic<std::size_t> dequeue_pos{0};
    std::atomic<uint64_t> dropped{0};

    LogRing() {
        for (std::size_t i = 0; i < cells.size(); ++i) cells[i].sequence.store(i, std::memory_order_relaxed);
    }
};
static_assert((runtime::kLogLines & (runtime::kLogLines - 1)) == 0, "ring size must be a power of two");

LogRing &ring() {
    static LogRing instance;  // constructed on first use; irpd touches it before going RT
    return instance;
}

thread_local Cycle current_cycle{};
// initial-exec: libindurop is loaded with the program (irpd, a process module), so the pointer is
// one %fs-relative load away rather than a __tls_get_addr call (a dlopen() of libindurop takes it
// from glibc's static TLS reserve).
thread_local const runtime::RunAbort *run_abort __attribute__((tls_model("initial-exec"))) = nullptr;

}  // namespace

int printf(const char *format, ...) {
    LogRing &r = ring();
    std::size_t pos = r.enqueue_pos.load(std::memory_order_relaxed);
    LogCell *cell;
    for (;;) {
        cell = &r.cells[pos & (runtime::kLogLines - 1)];
        std::size_t seq = cell->sequence.load(std::memory_order_acquire);
        auto diff = static_cast<std::ptrdiff_t>(seq) - static_cast<std::ptrdiff_t>(pos);
        if (diff == 0) {
            if (r.enqueue_pos.compare_exchange_weak(pos, pos + 1, std::memory_order_relaxed)) break;
        } else if (diff < 0) {
            r.dropped.fetch_add(1, std::memory_order_relaxed);
            return -1;
        } else {
            pos = r.enqueue_pos.load(std::memory_order_relaxed);
        }
    }
    va_list args;
    va_start(args, format);
    int n = std::vsnprintf(cell->text, sizeof cell->text, format, args);
    va_end(args);
    if (n < 0) n = 0;
    if (static_cast<std::size_t>(n) >= sizeof cell->text) n = sizeof cell->text - 1;
    cell->length = static_cast<uint32_t>(n);
    cell->sequence.store(pos + 1, std::memory_order_release);
    return n;
}

const Cycle &cycle() noexcept { return current_cycle; }

bool runAbortRequested() noexcept {
    const runtime::RunAbort *abort = run_abort;
    return abort && abort->now();
}

namespace runtime {

void setCycle(const Cycle &cycle) noexcept { current_cycle = cycle; }

void setRunAbort(const RunAbort *abort) noexcept { run_abort = abort; }

std::size_t drainLog(const std::function<void(std::string_view)> &sink) {
    LogRing &r = ring();
    std::size_t drained = 0;
    for (;;) {
        std::size_t pos = r.dequeue_pos.load(std::memory_order_relaxed);
        LogCell &cell = r.cells[pos & (kLogLines - 1)];
        std::size_t seq = cell.sequence.load(std::memory_order_acquire);
        if (static_cast<std::ptrdiff_t>(seq) - static_cast<std::ptrdiff_t>(pos + 1) < 0) return drained;
        sink(std::string_view(cell.text, cell.length));
        r.dequeue_pos.store(pos + 1, std::memory_order_relaxed);
        cell.sequence.store(pos + kLogLines, std::memory_order_release);
        ++drained;
    }
}

uint64_t droppedLogLines() noexcept { return ring().dropped.load(std::memory_order_relaxed); }

}  // namespace runtime
}  // namespace irp
