// layout.hpp -- a layout.json written by glbc, read and checked before irpd builds a segment on it.
#pragma once

#include <indurop/result.hpp>
#include "sdk/layouts.hpp"

#include <cstdint>
#include <filesystem>
#include <string>

namespace irp::variables {

struct Layout {
    std::filesystem::path path;
    std::string text;         // the file as written: copied into the segment for path lookups
    std::string hash;         // 64 hex digits
    uint64_t data_size = 0;   // bytes, a multiple of 64
    uint32_t lock_count = 0;  // one per top-level variable, and the holes' (glbc --previous)
    std::size_t variables = 0;
    layouts::Model model;  // the variables' places and the lineage, for online change
};

inline constexpr uint64_t kMaxDataSize = 1ull << 30;
inline constexpr std::size_t kMaxLayoutBytes = 64u << 20;

// Reads and checks a layout.json: format and version, the hash, every variable inside the data
// area and naming a lock that exists.  Errors name the file and what is wrong.
Result<Layout> readLayout(const std::filesystem::path &path);

}  // namespace irp::variables
