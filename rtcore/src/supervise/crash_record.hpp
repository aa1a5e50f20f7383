// crash_record.hpp -- what irpd leaves behind when a crash kills it, and what the next start does
// with it.  A thread module's segfault cannot be contained in-process: the handler installed here
// (async-signal-safe, on an alternate stack) writes which module was running on which executor,
// the signal, the time and the set into --state-dir, then lets the process die of the signal so
// that systemd restarts it.  The next start reads the record: a "crash" event, a `status` field,
// and, when the module's <on_crash> says exclude (the default), the set starts without running
// that module until someone enables it again (docs/supervision.md).
#pragma once

#include <indurop/result.hpp>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace irp::supervise {

struct CrashRecord {
    int signal = 0;
    std::string signal_name;   // "SIGSEGV"
    int64_t time_ns = 0;       // CLOCK_REALTIME
    int64_t pid = 0, tid = 0;  // the process and the thread that crashed
    std::string executor;      // "main", an <executor>'s name, "lifecycle" (initialize/start/stop), "" (other thread)
    std::string module;        // the module whose code was running, "" when none is known
    std::string set;           // module.xml of the running set
    std::string set_id;
    uint64_t generation = 0;
    std::string fault_address;  // si_addr, "0x..."
    // The instruction the crashing thread was at (the signal's ucontext), "" when not known; for a
    // fault in a module's code: that module, the file it was loaded from, the instruction's
    // offset from its load base, and the source line it maps to (taken in at the next start:
    // supervise/source_line.hpp), "" when not known.
    std::string pc;
    std::string code_module, code_image, code_offset;
    std::string source;       // "main.st:12"
    int64_t sender_pid = -1;  // who sent the signal (kill, abort, systemd), -1: the kernel, for a fault
    bool stuck = false;       // the watchdog's kill, and `module` is where a stalled dispatcher was stuck

    // "fault" (the kernel, for the crashed thread's own instruction), "abort" (irpd raised it
    // itself), "watchdog" (SIGABRT from pid 1: systemd's WatchdogSec), "signal" (another sender).
    const char *cause() const;

    nlohmann::ordered_json toJson() const;
    std::string describe() const;  // one line for the log and the event
};

// The files of one irpd instance in the state folder:
//   <instance>.crash         written by the crash handler, taken in (renamed) at the next start
//   <instance>.last-crash    the last crash taken in, for `status`
//   <instance>.excluded      modules left out after a crash: "<module>\t<set path>" per line
class CrashState {
public:
    // Opens (creates, mode 0750) the folder, takes in a record left by the previous run.
    static Result<std::unique_ptr<CrashState>> open(const std::filesystem::path &dir, const std::string &instance);
    ~CrashState();

    const std::filesystem::path &dir() const { return dir_; }
    // The crash that ended the previous run (null if it did not end by a crash).
    const std::optional<CrashRecord> &fresh() const { return fresh_; }
    // The last crash recorded, until clear().
    std::optional<CrashRecord> last() const;

    // Modules of `set` left out after crashes (persisted).
    std::set<std::string> excluded(const std::string &set) const;
    std::vector<std::pair<std::string, std::string>> allExcluded() const;  // (module, set)
    Status exclude(const std::string &set, const std::string &module);
    // `module` runs again from now on (enabled by hand); true if it was left out.
    bool forgive(const std::string &module);
    // Forgets the last crash and every exclusion: {"crash": the record or null, "excluded": [...]}.
    nlohmann::ordered_json clear();

    // Installs the handler for SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT (process-wide, before any
    // thread exists); from then on a crash writes <instance>.crash.
    Status arm();
    // The dispatcher (executor index) that holds systemd's watchdog pings back, -1: none
    // (SystemdNotify::stalled(), after each tick).  When systemd's watchdog kills irpd, the
    // module that dispatcher is stuck in is named in the record, as a crash in it would be.
    static void noteStalled(int dispatcher);
    // What the record names as the running set; called after every swap (non-RT).
    void setContext(const std::string &set, const std::string &set_id, uint64_t generation);
    // A clean stop: handlers back to the default.
    void disarm();

private:
    CrashState() = default;
    Status saveExcluded() const;  // with mutex_ held

    std::filesystem::path dir_;
    std::string instance_;
    std::optional<CrashRecord> fresh_;
    mutable std::mutex mutex_;  // last_, excluded_ (the control thread reads, the main thread writes)
    std::optional<CrashRecord> last_;
    std::vector<std::pair<std::string, std::string>> excluded_;
    int dir_fd_ = -1;
};

// Parses a record file's text; nullopt if it is not one.
std::optional<CrashRecord> parseCrashRecord(const std::string &text);

}  // namespace irp::supervise
