// retain_file.cpp -- the retain store's file: header + CBOR entries, SHA-256 over both, written
// through osal::writeAtomically.  Header (little-endian, kHeaderSize bytes):
//   0 magic "IRPRETN1"   8 u32 format version   12 u32 header size   16 u64 sequence
//  24 u64 content size  32 SHA-256 (computed with these 32 bytes zero)   64 identity (64 chars)
// 128 zero
#include "retain/retain_file.hpp"

#include <nlohmann/json.hpp>
#include <openssl/evp.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>

namespace irp::retain {
namespace {

constexpr std::size_t kSequenceAt = 16, kContentSizeAt = 24, kDigestAt = 32, kIdentityAt = 64;
constexpr std::size_t kDigestBytes = 32;

template <class T>
void put(std::string &out, std::size_t at, T value) {
    std::memcpy(out.data() + at, &value, sizeof value);
}
template <class T>
T get(std::string_view in, std::size_t at) {
    T value{};
    std::memcpy(&value, in.data() + at, sizeof value);
    return value;
}

// SHA-256 of the file with its digest field zero.
std::string digest(std::string file) {
    std::memset(file.data() + kDigestAt, 0, kDigestBytes);
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int n = 0;
    EVP_Digest(file.data(), file.size(), md, &n, EVP_sha256(), nullptr);
    return std::string(reinterpret_cast<const char *>(md), kDigestBytes);
}

}  // namespace

std::string encode(const Snapshot &snapshot) {
    nlohmann::json entries = nlohmann::json::array();
    for (const Entry &e : snapshot.entries)
        entries.push_back({{"path", e.path},
                           {"type", e.type},
                           {"type_id", e.type_id},
                           {"kind", e.kind},
                           {"value", nlohmann::json::binary(e.bytes)}});
    const std::vector<uint8_t> content = nlohmann::json::to_cbor(nlohmann::json{{"entries", std::move(entries)}});
    std::string file(kHeaderSize, '\0');
    std::memcpy(file.data(), kMagic, sizeof kMagic);
    put<uint32_t>(file, 8, kFormatVersion);
    put<uint32_t>(file, 12, static_cast<uint32_t>(kHeaderSize));
    put<uint64_t>(file, kSequenceAt, snapshot.sequence);
    put<uint64_t>(file, kContentSizeAt, content.size());
    std::memcpy(file.data() + kIdentityAt, snapshot.identity.data(),
                std::min(snapshot.identity.size(), kIdentityChars));
    file.append(content.begin(), content.end());
    const std::string sum = digest(file);
    std::memcpy(file.data() + kDigestAt, sum.data(), kDigestBytes);
    return file;
}

Result<Snapshot> decode(std::string_view bytes) {
    if (bytes.size() < kHeaderSize)
        return Error{"short: " + std::to_string(bytes.size()) + " bytes, less than the header's " +
                     std::to_string(kHeaderSize)};
    if (std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0) return Error{"not a retain store (no IRPRETN1 magic)"};
    if (const auto v = get<uint32_t>(bytes, 8); v != kFormatVersion || get<uint32_t>(bytes, 12) != kHeaderSize)
        return Error{"format version " + std::to_string(v) + ", not " + std::to_string(kFormatVersion)};
    const auto content_size = get<uint64_t>(bytes, kContentSizeAt);
    if (content_size > kMaxContentBytes || bytes.size() != kHeaderSize + content_size)
        return Error{"torn: " + std::to_string(bytes.size()) + " bytes, the header says " +
                     std::to_string(kHeaderSize + content_size)};
    if (digest(std::string(bytes)) != bytes.substr(kDigestAt, kDigestBytes))
        return Error{"corrupt: the SHA-256 of its content does not match its header"};
    Snapshot s;
    s.sequence = get<uint64_t>(bytes, kSequenceAt);
    const std::string_view identity = bytes.substr(kIdentityAt, kIdentityChars);
    s.identity = std::string(identity.substr(0, identity.find('\0')));
    try {
        const nlohmann::json doc = nlohmann::json::from_cbor(bytes.substr(kHeaderSize));
        for (const nlohmann::json &e : doc.at("entries"))
            s.entries.push_back(Entry{e.at("path").get<std::string>(), e.at("type").get<std::string>(),
                                      e.at("type_id").get<std::string>(), e.at("kind").get<std::string>(),
                                      e.at("value").get_binary()});
    } catch (const nlohmann::json::exception &e) {
        return Error{std::string("its entries do not decode: ") + e.what()};
    }
    return s;
}

Loaded loadCopies(const std::filesystem::path &a, const std::filesystem::path &b) {
    Loaded loaded;
    for (const std::filesystem::path &file : {a, b}) {
        std::error_code ec;
        if (!std::filesystem::exists(file, ec)) continue;  // not written yet
        if (std::filesystem::file_size(file, ec) > kHeaderSize + kMaxContentBytes) {
            loaded.bad.emplace_back(file, "larger than any retain store");
            continue;
        }
        std::ifstream in(file, std::ios::binary);
        if (!in) {
            loaded.bad.emplace_back(file, std::string("cannot read: ") + std::strerror(errno));
            continue;
        }
        const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        auto snapshot = decode(bytes);
        if (!snapshot) {
            loaded.bad.emplace_back(file, snapshot.error().message);
            continue;
        }
        if (!loaded.newest || snapshot->sequence > loaded.newest->sequence) {
            loaded.newest = std::move(*snapshot);
            loaded.newest_file = file;
        }
    }
    return loaded;
}

}  // namespace irp::retain
