// subprocess.hpp -- start a program with its output in files, wait for it with a deadline, stop
// it by pid.  For the tests that drive the irpd binary from outside.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace testing_support {

inline std::string readFile(const std::filesystem::path &p) {
    std::ifstream in(p);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

// A scratch folder removed at the end of the test.
struct TempDir {
    std::filesystem::path path;
    TempDir() {
        char tmpl[] = "/tmp/indurop-test-XXXXXX";
        path = mkdtemp(tmpl);
    }
    ~TempDir() { std::filesystem::remove_all(path); }
};

class Process {
public:
    // in_child runs in the child before exec (e.g. setenv with the child's own pid).
    Process(std::vector<std::string> argv, const std::filesystem::path &dir, std::function<void()> in_child = {})
        : out_(dir / "stdout"), err_(dir / "stderr") {
        pid_ = fork();
        if (pid_ == 0) {
            FILE *o = std::fopen(out_.c_str(), "w");
            FILE *e = std::fopen(err_.c_str(), "w");
            dup2(fileno(o), 1);
            dup2(fileno(e), 2);
            sigset_t none;
            sigemptyset(&none);
            sigprocmask(SIG_SETMASK, &none, nullptr);
            if (in_child) in_child();
            std::vector<char *> args;
            for (auto &a : argv) args.push_back(a.data());
            args.push_back(nullptr);
            execvp(args[0], args.data());
            _exit(127);
        }
    }
    ~Process() {
        if (pid_ > 0 && !exited_) {
            kill(pid_, SIGKILL);
            waitpid(pid_, nullptr, 0);
        }
    }

    pid_t pid() const { return pid_; }
    std::string out() const { return readFile(out_); }
    std::string err() const { return readFile(err_); }

    // The signal that ended it (after wait() saw it end by one), else 0.
    int termSignal() const { return term_signal_; }

    // Exit status, or -1 if still running at the deadline (-2 if killed by a signal).
    int wait(std::chrono::milliseconds limit = std::chrono::seconds(30)) {
        if (exited_) return status_;
        auto end = std::chrono::steady_clock::now() + limit;
        while (std::chrono::steady_clock::now() < end) {
            int status = 0;
            if (waitpid(pid_, &status, WNOHANG) == pid_) {
                exited_ = true;
                status_ = WIFEXITED(status) ? WEXITSTATUS(status) : -2;
                term_signal_ = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
                return status_;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        return -1;
    }

    // Waits until stderr (stdout) holds `text`.
    bool waitForErr(const std::string &text, std::chrono::milliseconds limit = std::chrono::seconds(20)) {
        return waitFor(err_, text, limit);
    }
    bool waitForOut(const std::string &text, std::chrono::milliseconds limit = std::chrono::seconds(20)) {
        return waitFor(out_, text, limit);
    }

private:
    static bool waitFor(const std::filesystem::path &file, const std::string &text, std::chrono::milliseconds limit) {
        auto end = std::chrono::steady_clock::now() + limit;
        while (std::chrono::steady_clock::now() < end) {
            if (readFile(file).find(text) != std::string::npos) return true;
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        return false;
    }

    pid_t pid_ = -1;
    bool exited_ = false;
    int status_ = -1;
    int term_signal_ = 0;
    std::filesystem::path out_, err_;
};

}  // namespace testing_support
