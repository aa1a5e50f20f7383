// retain_file.hpp -- one copy of the retain store on disk (docs/retain.md "The files"): a fixed
// header (magic, format version, sequence number, the program's identity, the content's size and a
// SHA-256 over header and content), then the entries as CBOR (path, type, type_id, kind, bytes).
// Written by osal::writeAtomically (a new file, fsync'ed, renamed over the old name): the name never
// holds a torn file; a copy torn or corrupt anyway (a disk that lies, a copy cut short) is refused
// by decode(), naming what is wrong.
#pragma once

#include <indurop/result.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace irp::retain {

inline constexpr char kMagic[8] = {'I', 'R', 'P', 'R', 'E', 'T', 'N', '1'};
inline constexpr uint32_t kFormatVersion = 1;
inline constexpr std::size_t kHeaderSize = 160;
inline constexpr std::size_t kIdentityChars = 64;          // a layout hash: 64 hex digits
inline constexpr std::size_t kMaxContentBytes = 1u << 30;  // the largest segment irpd makes

// One retained variable's value as it was saved.
struct Entry {
    std::string path, type, type_id;
    std::string kind;  // "retain" or "persistent"
    std::vector<uint8_t> bytes;
    bool operator==(const Entry &) const = default;
};

struct Snapshot {
    uint64_t sequence = 0;
    std::string identity;  // the layout hash of the program that saved it
    std::vector<Entry> entries;
};

// The file's bytes.
std::string encode(const Snapshot &snapshot);
// The snapshot, or why these bytes are not a good copy (short, not a retain file, another format
// version, a checksum that does not match, content that does not decode).
Result<Snapshot> decode(std::string_view bytes);

// What the two copies held at start.
struct Loaded {
    std::optional<Snapshot> newest;  // the good copy with the higher sequence, if any
    std::filesystem::path newest_file;
    std::vector<std::pair<std::filesystem::path, std::string>> bad;  // a copy that exists but is no good: why
};
Loaded loadCopies(const std::filesystem::path &a, const std::filesystem::path &b);

}  // namespace irp::retain
