// module_cache.cpp -- SHA-256 (OpenSSL's EVP) and the copies.
#include "hosts/module_cache.hpp"

#include <openssl/evp.h>

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <memory>
#include <system_error>
#include <vector>

namespace irp::hosts {

Result<std::string> sha256File(const std::filesystem::path &file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) return Error{"cannot read " + file.string()};
    std::unique_ptr<EVP_MD_CTX, void (*)(EVP_MD_CTX *)> ctx(EVP_MD_CTX_new(), EVP_MD_CTX_free);
    if (!ctx || EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr) != 1) return Error{"SHA-256 is not available"};
    std::vector<char> buffer(1 << 16);
    while (in) {
        in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
        if (in.gcount() > 0) EVP_DigestUpdate(ctx.get(), buffer.data(), static_cast<std::size_t>(in.gcount()));
    }
    if (in.bad()) return Error{"error reading " + file.string()};
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int size = 0;
    EVP_DigestFinal_ex(ctx.get(), digest, &size);
    return hexDigest(digest, size);
}

std::string hexDigest(const unsigned char *digest, unsigned size) {
    std::string hex;
    char two[3];
    for (unsigned i = 0; i < size; ++i) {
        std::snprintf(two, sizeof two, "%02x", digest[i]);
        hex += two;
    }
    return hex;
}

Result<ModuleCache> ModuleCache::open(const std::filesystem::path &dir) {
    if (dir.empty()) return Error{"the module cache needs a directory (--module-cache)"};
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) return Error{"module cache " + dir.string() + ": " + ec.message()};
    ::chmod(dir.c_str(), 0700);
    ModuleCache cache;
    cache.dir_ = std::filesystem::absolute(dir);
    return cache;
}

Result<ModuleCache::Entry> ModuleCache::put(const std::filesystem::path &file) const {
    auto hash = sha256File(file);
    if (!hash) return hash.error();
    Entry entry{*hash, dir_ / (*hash + "-" + file.filename().string())};
    std::error_code ec;
    if (std::filesystem::is_regular_file(entry.image, ec)) return entry;
    const std::filesystem::path temporary = entry.image.string() + ".tmp" + std::to_string(::getpid());
    std::filesystem::copy_file(file, temporary, std::filesystem::copy_options::overwrite_existing, ec);
    if (!ec)
        std::filesystem::permissions(temporary, std::filesystem::perms::owner_read | std::filesystem::perms::group_read,
                                     ec);
    if (!ec) std::filesystem::rename(temporary, entry.image, ec);
    if (ec) {
        std::filesystem::remove(temporary, ec);
        return Error{"cannot copy " + file.string() + " into the module cache " + dir_.string() + ": " + ec.message()};
    }
    // The copy must hold what was hashed (the file may have been rewritten meanwhile).
    auto copied = sha256File(entry.image);
    if (!copied || *copied != entry.sha256) {
        std::filesystem::remove(entry.image, ec);
        return Error{file.string() + " changed while it was being loaded; try again"};
    }
    return entry;
}

void ModuleCache::prune(const std::vector<std::filesystem::path> &keep) const {
    std::error_code ec;
    for (const auto &item : std::filesystem::directory_iterator(dir_, ec)) {
        const auto name = item.path().filename();
        if (std::none_of(keep.begin(), keep.end(), [&](const auto &k) { return k.filename() == name; }))
            std::filesystem::remove(item.path(), ec);
    }
}

}  // namespace irp::hosts
