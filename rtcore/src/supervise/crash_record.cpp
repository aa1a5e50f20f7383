// crash_record.cpp -- the crash handler (async-signal-safe: fixed buffers, write/fsync/renameat on
// descriptors opened in advance) and the record's files in the state folder.
#include "supervise/crash_record.hpp"

#include "dispatch/running_marker.hpp"
#include "events/event_log.hpp"
#include "osal/atomic_file.hpp"
#include "supervise/module_code.hpp"
#include "supervise/source_line.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/ucontext.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>

namespace irp::supervise {
namespace {

constexpr int kCrashSignals[] = {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT};

// What the handler needs, prepared beforehand.  The set's context is double-buffered: the main
// thread writes the other half and then flips `current`.
struct HandlerState {
    int dir_fd = -1;
    char tmp_name[128] = {};
    char record_name[128] = {};
    struct Context {
        char set[1024] = {};
        char set_id[256] = {};
        uint64_t generation = 0;
    } context[2];
    std::atomic<int> current{0};
    std::atomic<bool> handling{false};
    std::atomic<int> stalled{-1};  // the dispatcher holding the watchdog's pings back
    char buffer[8192] = {};
    CodeLocation code;
};
HandlerState g_handler;

// Appends to a fixed buffer without anything that is not async-signal-safe.
struct Writer {
    char *out;
    std::size_t size, used = 0;
    void text(const char *s) {
        while (s && *s && used + 1 < size) out[used++] = *s++;
    }
    void number(uint64_t v) {
        char digits[24];
        int n = 0;
        do digits[n++] = static_cast<char>('0' + v % 10);
        while ((v /= 10) && n < 24);
        while (n && used + 1 < size) out[used++] = digits[--n];
    }
    void hex(uint64_t v) {
        text("0x");
        char digits[17];
        int n = 0;
        do digits[n++] = "0123456789abcdef"[v & 15];
        while ((v >>= 4) && n < 16);
        while (n && used + 1 < size) out[used++] = digits[--n];
    }
    void field(const char *key, const char *value) { text(key), text("="), text(value), text("\n"); }
    void field(const char *key, uint64_t value) { text(key), text("="), number(value), text("\n"); }
};

const char *signalName(int sig) {
    switch (sig) {
    case SIGSEGV: return "SIGSEGV";
    case SIGBUS: return "SIGBUS";
    case SIGFPE: return "SIGFPE";
    case SIGILL: return "SIGILL";
    case SIGABRT: return "SIGABRT";
    default: return "?";
    }
}

// The instruction the interrupted thread was at, from the context the kernel saved; 0 if unknown.
uintptr_t interruptedPc(void *context) {
    if (!context) return 0;
    const auto *uc = static_cast<const ucontext_t *>(context);
#if defined(__x86_64__)
    return static_cast<uintptr_t>(uc->uc_mcontext.gregs[REG_RIP]);
#elif defined(__aarch64__)
    return static_cast<uintptr_t>(uc->uc_mcontext.pc);
#else
    (void)uc;
    return 0;
#endif
}

void onCrash(int sig, siginfo_t *info, void *context) {
    // One record: a second thread crashing meanwhile waits for the first to end the process.
    if (g_handler.handling.exchange(true)) {
        for (;;) pause();
    }
    const int saved_errno = errno;
    const int tid = static_cast<int>(syscall(SYS_gettid));
    timespec now{};
    clock_gettime(CLOCK_REALTIME, &now);
    Writer w{g_handler.buffer, sizeof g_handler.buffer};
    w.text("indurop-crash 1\n");
    w.field("signal", static_cast<uint64_t>(sig));
    w.field("signal_name", signalName(sig));
    w.field("time_ns", static_cast<uint64_t>(now.tv_sec) * 1'000'000'000ull + static_cast<uint64_t>(now.tv_nsec));
    w.field("pid", static_cast<uint64_t>(getpid()));
    w.field("tid", static_cast<uint64_t>(tid));
    // Whose code.  A fault, or irpd's own abort(): the marker of the thread it hit (an executor,
    // or the main thread in a lifecycle call).  A signal sent to the process reaches whichever
    // thread the kernel picks, so that thread's module says nothing and is not blamed -- except
    // for systemd's watchdog (SIGABRT from pid 1), which fires because a dispatcher stopped making
    // progress: the module that dispatcher's marker shows is the one stuck, or failing that a
    // module's initialize/start/stop that kept the main thread past the reload's allowance.
    const bool sent = info && info->si_code <= 0;
    const char *module = nullptr, *executor = nullptr;
    bool stuck = false;
    if (!sent || info->si_pid == getpid()) {
        for (dispatch::RunningMarker &m : dispatch::g_running_markers)
            if (m.tid.load(std::memory_order_relaxed) == tid) {
                module = m.module.load(std::memory_order_relaxed);
                executor = m.executor;
                if (module) break;
            }
    } else if (sig == SIGABRT && info->si_pid == 1) {
        const int stalled = g_handler.stalled.load(std::memory_order_relaxed);
        for (int index : {stalled, static_cast<int>(dispatch::kLifecycleMarker)}) {
            if (index < 0 || index >= static_cast<int>(dispatch::kMaxMarkedExecutors)) continue;
            dispatch::RunningMarker &m = dispatch::g_running_markers[index];
            if (const char *name = m.module.load(std::memory_order_relaxed)) {
                module = name, executor = m.executor, stuck = true;
                break;
            }
        }
    }
    w.field("executor", executor && module ? executor : "");
    w.field("module", module ? module : "");
    if (stuck) w.field("stuck", 1);
    const HandlerState::Context &c = g_handler.context[g_handler.current.load(std::memory_order_acquire)];
    w.field("set", c.set);
    w.field("set_id", c.set_id);
    w.field("generation", c.generation);
    w.text("fault_address="), w.hex(reinterpret_cast<uintptr_t>(info ? info->si_addr : nullptr)), w.text("\n");
    // For a fault: the instruction, and in whose code (a table of numbers: dladdr is not
    // async-signal-safe).  A signal that was sent (a kill, irpd's own abort) finds the thread
    // wherever it was: that place says nothing.
    if (const uintptr_t pc = sent ? 0 : interruptedPc(context)) {
        w.text("pc="), w.hex(pc), w.text("\n");
        if (findModuleCode(pc, g_handler.code)) {
            w.field("code_module", g_handler.code.module);
            w.field("code_image", g_handler.code.image);
            w.text("code_offset="), w.hex(g_handler.code.offset), w.text("\n");
        }
    }
    // Sent (kill, tgkill, sigqueue: si_code <= 0) rather than raised by the kernel for a fault:
    // the sender's pid -- irpd's own for abort(), 1 for systemd's watchdog.
    if (sent) w.field("sender_pid", static_cast<uint64_t>(info->si_pid));
    if (g_handler.dir_fd >= 0) {
        int fd = openat(g_handler.dir_fd, g_handler.tmp_name, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0640);
        if (fd >= 0) {
            std::size_t done = 0;
            while (done < w.used) {
                ssize_t n = write(fd, w.out + done, w.used - done);
                if (n <= 0) break;
                done += static_cast<std::size_t>(n);
            }
            fsync(fd);
            close(fd);
            renameat(g_handler.dir_fd, g_handler.tmp_name, g_handler.dir_fd, g_handler.record_name);
            fsync(g_handler.dir_fd);
        }
    }
    // Back to the default action, and the signal again: the process dies of it (SA_RESETHAND
    // already restored the default; raised while blocked, it is delivered when this returns, and
    // a fault's instruction faults again).
    struct sigaction dfl {};
    dfl.sa_handler = SIG_DFL;
    sigemptyset(&dfl.sa_mask);
    sigaction(sig, &dfl, nullptr);
    raise(sig);
    errno = saved_errno;
}

std::string readText(const std::filesystem::path &p) {
    std::ifstream in(p);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

}  // namespace

std::optional<CrashRecord> parseCrashRecord(const std::string &text) {
    std::istringstream in(text);
    std::string line;
    if (!std::getline(in, line) || line != "indurop-crash 1") return std::nullopt;
    CrashRecord r;
    while (std::getline(in, line)) {
        const auto eq = line.find('=');
        if (eq == std::string::npos) continue;
        const std::string key = line.substr(0, eq), value = line.substr(eq + 1);
        auto number = [&] {
            try {
                return static_cast<int64_t>(std::stoll(value));
            } catch (...) {
                return int64_t{0};
            }
        };
        if (key == "signal")
            r.signal = static_cast<int>(number());
        else if (key == "signal_name")
            r.signal_name = value;
        else if (key == "time_ns")
            r.time_ns = number();
        else if (key == "pid")
            r.pid = number();
        else if (key == "tid")
            r.tid = number();
        else if (key == "executor")
            r.executor = value;
        else if (key == "module")
            r.module = value;
        else if (key == "set")
            r.set = value;
        else if (key == "set_id")
            r.set_id = value;
        else if (key == "generation")
            r.generation = static_cast<uint64_t>(number());
        else if (key == "fault_address")
            r.fault_address = value;
        else if (key == "sender_pid")
            r.sender_pid = number();
        else if (key == "stuck")
            r.stuck = number() != 0;
        else if (key == "pc")
            r.pc = value;
        else if (key == "code_module")
            r.code_module = value;
        else if (key == "code_image")
            r.code_image = value;
        else if (key == "code_offset")
            r.code_offset = value;
        else if (key == "source")
            r.source = value;
    }
    if (!r.signal) return std::nullopt;
    return r;
}

nlohmann::ordered_json CrashRecord::toJson() const {
    const auto orNull = [](const std::string &s) {
        return s.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(s);
    };
    return {{"signal", signal_name},
            {"signal_number", signal},
            {"time", events::isoTime(time_ns)},
            {"module", module.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(module)},
            {"executor", executor.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(executor)},
            {"set", set},
            {"set_id", set_id.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(set_id)},
            {"generation", generation},
            {"pid", pid},
            {"thread", tid},
            {"fault_address", fault_address},
            {"pc", orNull(pc)},
            {"code_module", orNull(code_module)},
            {"code_offset", orNull(code_offset)},
            {"source", orNull(source)},
            {"sender_pid", sender_pid < 0 ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(sender_pid)},
            {"cause", cause()},
            {"stuck", stuck}};
}

const char *CrashRecord::cause() const {
    if (sender_pid < 0) return "fault";
    if (sender_pid == pid) return "abort";
    if (sender_pid == 1 && signal == SIGABRT) return "watchdog";
    return "signal";
}

std::string CrashRecord::describe() const {
    std::string where = module.empty() ? "outside any module's code (thread " + std::to_string(tid) + ")"
                                       : "in module '" + module + "'" +
                                             (executor == "lifecycle" ? " (initialize/start/stop, on the main thread)"
                                                                      : " on executor '" + executor + "'");
    if (!source.empty())
        where += ", at " + source + " (" + code_module + "+" + code_offset + ")";
    else if (!code_offset.empty())
        where += ", at " + code_module + "+" + code_offset + " (no source line known)";
    if (stuck) where += ", stuck there (its dispatcher made no progress)";
    const std::string why = cause();
    const std::string how = why == "abort"      ? " raised by irpd itself (abort)"
                            : why == "watchdog" ? " from systemd's watchdog (pid 1)"
                            : why == "signal"   ? " from pid " + std::to_string(sender_pid)
                                                : "";
    return "irpd pid " + std::to_string(pid) + " died of " + signal_name + how + " " + where + " at " +
           events::isoTime(time_ns) + " (set " + set + ", generation " + std::to_string(generation) + ")";
}

Result<std::unique_ptr<CrashState>> CrashState::open(const std::filesystem::path &dir, const std::string &instance) {
    std::unique_ptr<CrashState> s(new CrashState());
    s->dir_ = dir;
    s->instance_ = instance;
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) return Error{"state folder " + dir.string() + ": " + ec.message() + " (see --state-dir)"};
    chmod(dir.c_str(), 0750);
    s->dir_fd_ = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (s->dir_fd_ < 0 || faccessat(s->dir_fd_, ".", W_OK, AT_EACCESS) != 0)
        return Error{"state folder " + dir.string() + " is not a writable folder: " + std::strerror(errno) +
                     " (see --state-dir)"};

    const std::filesystem::path record = dir / (instance + ".crash"), last = dir / (instance + ".last-crash");
    if (std::filesystem::exists(record)) {
        std::string text = readText(record);
        s->fresh_ = parseCrashRecord(text);
        if (s->fresh_) {
            // Now, not in the handler: the faulting instruction's source line, kept with the record.
            CrashRecord &r = *s->fresh_;
            if (!r.code_image.empty() && !r.code_offset.empty() && r.source.empty()) {
                r.source = sourceLine(r.code_image, std::strtoull(r.code_offset.c_str(), nullptr, 16));
                if (!r.source.empty()) text += "source=" + r.source + "\n";
            }
            if (osal::writeAtomically(last, text))
                std::filesystem::remove(record, ec);
            else
                std::filesystem::rename(record, last, ec);
        } else {
            std::filesystem::remove(record, ec);  // torn or foreign: not a record
        }
    }
    s->last_ = parseCrashRecord(readText(last));
    std::istringstream excluded(readText(dir / (instance + ".excluded")));
    std::string line;
    while (std::getline(excluded, line)) {
        const auto tab = line.find('\t');
        if (tab != std::string::npos) s->excluded_.emplace_back(line.substr(0, tab), line.substr(tab + 1));
    }
    return s;
}

CrashState::~CrashState() {
    if (dir_fd_ >= 0 && g_handler.dir_fd != dir_fd_) ::close(dir_fd_);
}

std::optional<CrashRecord> CrashState::last() const {
    std::lock_guard lock(mutex_);
    return last_;
}

std::set<std::string> CrashState::excluded(const std::string &set) const {
    std::lock_guard lock(mutex_);
    std::set<std::string> names;
    for (const auto &[module, s] : excluded_)
        if (s == set) names.insert(module);
    return names;
}

std::vector<std::pair<std::string, std::string>> CrashState::allExcluded() const {
    std::lock_guard lock(mutex_);
    return excluded_;
}

Status CrashState::saveExcluded() const {
    const std::filesystem::path path = dir_ / (instance_ + ".excluded");
    if (excluded_.empty()) {
        std::error_code ec;
        std::filesystem::remove(path, ec);
        return Ok{};
    }
    std::string text;
    for (const auto &[module, set] : excluded_) text += module + "\t" + set + "\n";
    return osal::writeAtomically(path, text);
}

Status CrashState::exclude(const std::string &set, const std::string &module) {
    std::lock_guard lock(mutex_);
    for (const auto &e : excluded_)
        if (e.first == module && e.second == set) return Ok{};
    excluded_.emplace_back(module, set);
    return saveExcluded();
}

bool CrashState::forgive(const std::string &module) {
    std::lock_guard lock(mutex_);
    const std::size_t before = excluded_.size();
    std::erase_if(excluded_, [&](const auto &e) { return e.first == module; });
    if (excluded_.size() == before) return false;
    (void)saveExcluded();
    return true;
}

nlohmann::ordered_json CrashState::clear() {
    std::lock_guard lock(mutex_);
    nlohmann::ordered_json excluded = nlohmann::ordered_json::array();
    for (const auto &[module, set] : excluded_) excluded.push_back({{"module", module}, {"set", set}});
    nlohmann::ordered_json answer = {{"crash", last_ ? last_->toJson() : nlohmann::ordered_json(nullptr)},
                                     {"excluded", excluded}};
    excluded_.clear();
    last_.reset();
    (void)saveExcluded();
    std::error_code ec;
    std::filesystem::remove(dir_ / (instance_ + ".last-crash"), ec);
    return answer;
}

Status CrashState::arm() {
    std::snprintf(g_handler.tmp_name, sizeof g_handler.tmp_name, "%s.crash.tmp", instance_.c_str());
    std::snprintf(g_handler.record_name, sizeof g_handler.record_name, "%s.crash", instance_.c_str());
    g_handler.dir_fd = dir_fd_;
    // The main thread's own alternate stack (the executors set up theirs, osal/rt.hpp).
    static char main_stack[64 * 1024];
    stack_t ss{};
    ss.ss_sp = main_stack;
    ss.ss_size = sizeof main_stack;
    sigaltstack(&ss, nullptr);
    for (int sig : kCrashSignals) {
        struct sigaction sa {};
        sa.sa_sigaction = onCrash;
        sa.sa_flags = SA_SIGINFO | SA_ONSTACK | SA_RESETHAND;
        sigemptyset(&sa.sa_mask);
        if (sigaction(sig, &sa, nullptr) != 0) return Error{std::string("sigaction: ") + std::strerror(errno)};
    }
    return Ok{};
}

void CrashState::noteStalled(int dispatcher) { g_handler.stalled.store(dispatcher, std::memory_order_relaxed); }

void CrashState::setContext(const std::string &set, const std::string &set_id, uint64_t generation) {
    const int next = 1 - g_handler.current.load(std::memory_order_relaxed);
    HandlerState::Context &c = g_handler.context[next];
    std::snprintf(c.set, sizeof c.set, "%s", set.c_str());
    std::snprintf(c.set_id, sizeof c.set_id, "%s", set_id.c_str());
    c.generation = generation;
    g_handler.current.store(next, std::memory_order_release);
}

void CrashState::disarm() {
    for (int sig : kCrashSignals) signal(sig, SIG_DFL);
    g_handler.dir_fd = -1;
}

}  // namespace irp::supervise
