// module_cache.hpp -- content-addressed copies of module files, from which irpd loads them.
//
// dlopen() of a path that is already loaded hands back the library loaded first, whatever the
// file holds now: a hot reload of a rebuilt module.so would silently keep running the old code.
// So every thread module is loaded from a copy named after its content's SHA-256,
// <dir>/<sha256>-<file name>: a changed file is a new path, and an unchanged one the same path
// (its library is then shared, not loaded twice).
#pragma once

#include <indurop/result.hpp>

#include <filesystem>
#include <string>
#include <vector>

namespace irp::hosts {

// The SHA-256 of a file's content, as 64 lowercase hex digits.
Result<std::string> sha256File(const std::filesystem::path &file);
// A digest as lowercase hex digits.
std::string hexDigest(const unsigned char *digest, unsigned size);

class ModuleCache {
public:
    // Uses (and creates, mode 0700) `dir`; an empty dir is refused.
    static Result<ModuleCache> open(const std::filesystem::path &dir);

    struct Entry {
        std::string sha256;
        std::filesystem::path image;  // the copy to load
    };
    // Hashes `file` and makes sure its copy exists (written to a temporary name, then renamed,
    // read-only).  A copy already there is reused.
    Result<Entry> put(const std::filesystem::path &file) const;

    // Removes the copies not named in keep (file names).  Best effort.
    void prune(const std::vector<std::filesystem::path> &keep) const;

    const std::filesystem::path &dir() const { return dir_; }

private:
    std::filesystem::path dir_;
};

}  // namespace irp::hosts
