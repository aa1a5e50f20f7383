// source_line.cpp -- `addr2line -e <image> <offset>` as a subprocess; see source_line.hpp.
#include "supervise/source_line.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <vector>

extern char **environ;

namespace irp::supervise {
namespace {

// The first line addr2line printed, as "<file name>:<line>"; "" for its "??:0" / "??:?".
std::string parse(const std::string &output) {
    std::string line = output.substr(0, output.find('\n'));
    if (const auto extra = line.find(" ("); extra != std::string::npos) line.erase(extra);  // "(discriminator 2)"
    const auto colon = line.rfind(':');
    if (colon == std::string::npos || colon == 0) return "";
    const std::string file = line.substr(0, colon), number = line.substr(colon + 1);
    if (file.find("??") != std::string::npos || number.empty() || number == "0" || number == "?") return "";
    return std::filesystem::path(file).filename().string() + ":" + number;
}

}  // namespace

std::string sourceLine(const std::filesystem::path &image, uintptr_t offset) {
    std::error_code ec;
    if (image.empty() || !std::filesystem::is_regular_file(image, ec)) return "";
    int out[2];
    if (pipe2(out, O_CLOEXEC) != 0) return "";
    char address[32];
    std::snprintf(address, sizeof address, "0x%llx", static_cast<unsigned long long>(offset));
    const std::string file = image.string();
    std::vector<char *> argv{const_cast<char *>("addr2line"), const_cast<char *>("-e"),
                             const_cast<char *>(file.c_str()), address, nullptr};
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, out[1], STDOUT_FILENO);
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
    pid_t pid = -1;
    const int spawned = posix_spawnp(&pid, "addr2line", &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    close(out[1]);
    std::string text;
    if (spawned == 0) {
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
        for (;;) {
            const auto left =
                std::chrono::duration_cast<std::chrono::milliseconds>(until - std::chrono::steady_clock::now()).count();
            pollfd p{out[0], POLLIN, 0};
            if (left <= 0 || poll(&p, 1, static_cast<int>(left)) <= 0) {
                kill(pid, SIGKILL);  // too slow: no source rather than a start held up
                text.clear();
                break;
            }
            char buffer[512];
            const ssize_t n = read(out[0], buffer, sizeof buffer);
            if (n <= 0) break;
            text.append(buffer, static_cast<std::size_t>(n));
        }
        int status = 0;
        while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
        if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) text.clear();
    }
    close(out[0]);
    return parse(text);
}

}  // namespace irp::supervise
