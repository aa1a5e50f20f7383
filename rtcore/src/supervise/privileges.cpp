// privileges.cpp -- the switch to --user with libcap: bounding set first (needs CAP_SETPCAP, so
// while still root), then groups and uid keeping the permitted set, then the kept set only, also
// ambient (so that a managed restart's exec keeps it); or, already that user after such an exec,
// the check that the kept set came along.
#include "supervise/privileges.hpp"

#include <grp.h>
#include <pwd.h>
#include <sys/capability.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <vector>

namespace irp::supervise {
namespace {

const cap_value_t kKept[] = {CAP_SYS_NICE, CAP_IPC_LOCK};

bool kept(cap_value_t c) {
    for (cap_value_t k : kKept)
        if (k == c) return true;
    return false;
}

int threadCount() {
    std::ifstream status("/proc/self/status");
    std::string line;
    while (std::getline(status, line))
        if (line.rfind("Threads:", 0) == 0) return std::atoi(line.c_str() + 8);
    return -1;
}

std::string lastError(const std::string &what) { return what + ": " + std::strerror(errno); }

}  // namespace

Result<Identity> resolveIdentity(const std::string &user, const std::string &group) {
    Identity who;
    errno = 0;
    const passwd *pw = getpwnam(user.c_str());
    if (!pw) return Error{"--user: no user '" + user + "' on this system"};
    who.user = user;
    who.uid = pw->pw_uid;
    who.gid = pw->pw_gid;
    if (!group.empty()) {
        const struct group *gr = getgrnam(group.c_str());
        if (!gr) return Error{"--group: no group '" + group + "' on this system"};
        who.gid = gr->gr_gid;
    }
    const struct group *gr = getgrgid(who.gid);
    who.group = gr ? gr->gr_name : std::to_string(who.gid);
    if (who.uid == 0) return Error{"--user " + user + " is root (uid 0): name an unprivileged user"};
    return who;
}

Status handOver(const std::filesystem::path &dir, const Identity &who) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) return Error{dir.string() + ": " + ec.message()};
    if (chown(dir.c_str(), who.uid, who.gid) != 0) return Error{lastError("chown " + dir.string())};
    return Ok{};
}

Status prepareFolderFor(const std::filesystem::path &file, const Identity &who) {
    const std::filesystem::path dir = std::filesystem::absolute(file).parent_path();
    struct stat st {};
    if (stat(dir.c_str(), &st) != 0) {
        if (Status st = handOver(dir, who); !st) return st;
        chmod(dir.c_str(), 0750);
        return Ok{};
    }
    const bool writable = (st.st_uid == who.uid && (st.st_mode & S_IWUSR) && (st.st_mode & S_IXUSR)) ||
                          (st.st_gid == who.gid && (st.st_mode & S_IWGRP) && (st.st_mode & S_IXGRP)) ||
                          ((st.st_mode & S_IWOTH) && (st.st_mode & S_IXOTH));
    if (!writable)
        return Error{"--user " + who.user + " may not create " + file.filename().string() + " in " + dir.string() +
                     ": give the folder to " + who.user + " (or its group, writable), or name a folder that does " +
                     "not exist yet (irpd then creates it for " + who.user + ")"};
    return Ok{};
}

namespace {

// After a managed restart irpd is `who` already: what it kept must have come along (ambient).
Status checkKept(const Identity &who) {
    if (getuid() != who.uid || geteuid() != who.uid || getgid() != who.gid || getegid() != who.gid)
        return Error{"irpd runs as uid " + std::to_string(geteuid()) + " gid " + std::to_string(getegid()) +
                     ", not --user " + who.user + ":" + who.group + "; start it as root or as that user and group"};
    cap_t caps = cap_get_proc();
    if (!caps) return Error{lastError("cap_get_proc")};
    std::string missing;
    for (cap_value_t c : kKept) {
        cap_flag_value_t on = CAP_CLEAR;
        cap_get_flag(caps, c, CAP_EFFECTIVE, &on);
        if (on != CAP_SET) missing += (missing.empty() ? "" : " and ") + std::string(cap_to_name(c));
    }
    cap_free(caps);
    if (!missing.empty())
        return Error{"irpd runs as --user " + who.user + " already but without " + missing +
                     " (kept across a restart only as ambient capabilities): start it as root"};
    if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0) return Error{lastError("PR_SET_NO_NEW_PRIVS")};
    return Ok{};
}

}  // namespace

Status dropPrivileges(const Identity &who) {
    if (geteuid() != 0 && getuid() == who.uid) return checkKept(who);
    if (const int n = threadCount(); n != 1)
        return Error{"cannot switch to --user " + who.user + ": irpd has " + std::to_string(n) +
                     " threads already (capabilities are per thread)"};
    if (!CAP_IS_SUPPORTED(CAP_SETUID) || geteuid() != 0)
        return Error{"--user " + who.user + " needs irpd to start as root (it keeps CAP_SYS_NICE and CAP_IPC_LOCK " +
                     "and drops the rest)"};
    // 1. The bounding set: every capability but the kept ones, for good.
    for (cap_value_t c = 0; c <= CAP_LAST_CAP; ++c)
        if (!kept(c) && CAP_IS_SUPPORTED(c) && cap_drop_bound(c) != 0)
            return Error{lastError("cap_drop_bound(" + std::string(cap_to_name(c)) + ")")};
    // 2. Groups and uid; libcap's helpers keep the permitted set across the uid change.
    const gid_t gid = who.gid;
    if (cap_setgroups(gid, 1, &gid) != 0) return Error{lastError("setting group " + who.group)};
    if (cap_setuid(who.uid) != 0) return Error{lastError("setting user " + who.user)};
    // 3. Only the kept capabilities: permitted, effective, inheritable and ambient (the last two so
    //    that they survive irpd's exec of itself in a managed restart; process modules drop the
    //    ambient set before their exec, hosts/process_supervisor.cpp).
    cap_t caps = cap_init();
    if (!caps) return Error{lastError("cap_init")};
    cap_set_flag(caps, CAP_PERMITTED, 2, kKept, CAP_SET);
    cap_set_flag(caps, CAP_EFFECTIVE, 2, kKept, CAP_SET);
    cap_set_flag(caps, CAP_INHERITABLE, 2, kKept, CAP_SET);
    const int rc = cap_set_proc(caps);
    cap_free(caps);
    if (rc != 0) return Error{lastError("cap_set_proc")};
    if (cap_reset_ambient() != 0 && errno != EINVAL) return Error{lastError("cap_reset_ambient")};
    for (cap_value_t c : kKept)
        if (cap_set_ambient(c, CAP_SET) != 0)
            return Error{lastError("raising " + std::string(cap_to_name(c)) + " as ambient")};
    if (prctl(PR_SET_KEEPCAPS, 0, 0, 0, 0) != 0) return Error{lastError("PR_SET_KEEPCAPS")};
    if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0) return Error{lastError("PR_SET_NO_NEW_PRIVS")};
    // The switch is complete or irpd does not go on: check what the kernel says now.
    if (getuid() != who.uid || geteuid() != who.uid || getgid() != who.gid || getegid() != who.gid)
        return Error{"the switch to " + who.user + " did not take"};
    return Ok{};
}

std::string describeCredentials() {
    cap_t caps = cap_get_proc();
    char *text = caps ? cap_to_text(caps, nullptr) : nullptr;
    std::string line = "uid " + std::to_string(getuid()) + " gid " + std::to_string(getgid()) + ", capabilities " +
                       (text ? text : "?");
    if (text) cap_free(text);
    if (caps) cap_free(caps);
    return line;
}

}  // namespace irp::supervise
