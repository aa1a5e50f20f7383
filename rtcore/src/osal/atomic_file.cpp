// atomic_file.cpp -- write, fsync, rename, fsync of the folder (atomic_file.hpp).
#include "osal/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

namespace irp::osal {
namespace {

std::string errnoText(const std::string &what, const std::filesystem::path &path) {
    return what + " " + path.string() + ": " + std::strerror(errno);
}

}  // namespace

Status writeAtomically(const std::filesystem::path &file, std::string_view bytes,
                       const std::function<void()> &before_rename) {
    const std::filesystem::path tmp = file.string() + ".tmp";
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0640);
    if (fd < 0) return Error{errnoText("cannot create", tmp)};
    for (std::size_t done = 0; done < bytes.size();) {
        const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            const std::string why = errnoText("cannot write", tmp);
            ::close(fd);
            return Error{why};
        }
        done += static_cast<std::size_t>(n);
    }
    if (::fsync(fd) != 0) {
        const std::string why = errnoText("cannot fsync", tmp);
        ::close(fd);
        return Error{why};
    }
    ::close(fd);
    if (before_rename) before_rename();
    if (::rename(tmp.c_str(), file.c_str()) != 0) return Error{errnoText("cannot rename to", file)};
    const std::filesystem::path folder = file.parent_path().empty() ? "." : file.parent_path();
    const int dir = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dir < 0) return Error{errnoText("cannot open", folder)};
    const int synced = ::fsync(dir);
    const std::string why = synced != 0 ? errnoText("cannot fsync", folder) : "";
    ::close(dir);
    if (synced != 0) return Error{why};
    return Ok{};
}

}  // namespace irp::osal
