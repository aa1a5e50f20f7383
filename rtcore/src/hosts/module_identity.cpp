// module_identity.cpp -- the loadable sections of a module's ELF file, hashed (libelf, OpenSSL).
#include "hosts/module_identity.hpp"

#include "hosts/module_cache.hpp"

#include <fcntl.h>
#include <gelf.h>
#include <libelf.h>
#include <openssl/evp.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <memory>

namespace irp::hosts {
namespace {

constexpr const char *kStampSection = ".indurop_layout";
constexpr const char *kBuildId = ".note.gnu.build-id";

struct Fd {
    int fd;
    ~Fd() {
        if (fd >= 0) ::close(fd);
    }
};

}  // namespace

Result<ModuleIdentity> identify(const std::filesystem::path &file) {
    if (elf_version(EV_CURRENT) == EV_NONE) return Error{"libelf: " + std::string(elf_errmsg(-1))};
    Fd fd{::open(file.c_str(), O_RDONLY | O_CLOEXEC)};
    if (fd.fd < 0) return Error{"cannot read " + file.string() + ": " + std::strerror(errno)};
    std::unique_ptr<Elf, int (*)(Elf *)> elf(elf_begin(fd.fd, ELF_C_READ, nullptr), elf_end);
    size_t names = 0;
    if (!elf || elf_kind(elf.get()) != ELF_K_ELF || elf_getshdrstrndx(elf.get(), &names) != 0) {
        auto whole = sha256File(file);  // not ELF (a script as a process module): its bytes
        if (!whole) return whole.error();
        return ModuleIdentity{*whole, ""};
    }
    std::unique_ptr<EVP_MD_CTX, void (*)(EVP_MD_CTX *)> ctx(EVP_MD_CTX_new(), EVP_MD_CTX_free);
    if (!ctx || EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr) != 1) return Error{"SHA-256 is not available"};
    ModuleIdentity id;
    for (Elf_Scn *scn = elf_nextscn(elf.get(), nullptr); scn; scn = elf_nextscn(elf.get(), scn)) {
        GElf_Shdr sh;
        if (!gelf_getshdr(scn, &sh)) return Error{file.string() + ": unreadable section header: " + elf_errmsg(-1)};
        const char *name = elf_strptr(elf.get(), names, sh.sh_name);
        if (!name || !(sh.sh_flags & SHF_ALLOC)) continue;
        const bool stamp = std::strcmp(name, kStampSection) == 0;
        Elf_Data *data = sh.sh_type == SHT_NOBITS ? nullptr : elf_getdata(scn, nullptr);
        if (stamp && data && data->d_buf) {
            const auto *text = static_cast<const char *>(data->d_buf);
            id.layout.assign(text, strnlen(text, data->d_size));
        }
        const struct { uint64_t addr, size, flags, type; } shape{sh.sh_addr, sh.sh_size, sh.sh_flags, sh.sh_type};
        EVP_DigestUpdate(ctx.get(), name, std::strlen(name) + 1);
        EVP_DigestUpdate(ctx.get(), &shape, sizeof shape);
        if (stamp || std::strcmp(name, kBuildId) == 0) continue;  // their size counted, not their bytes
        for (Elf_Data *d = data; d; d = elf_getdata(scn, d))
            if (d->d_buf && d->d_size) EVP_DigestUpdate(ctx.get(), d->d_buf, d->d_size);
    }
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int size = 0;
    EVP_DigestFinal_ex(ctx.get(), digest, &size);
    id.code = hexDigest(digest, size);
    return id;
}

}  // namespace irp::hosts
