// journal.cpp -- fixed-size, allocation-free append so that it can be called from run().
#include "journal.hpp"

#include <atomic>
#include <cstring>

namespace journal {
namespace {

struct Raw {
    char who[32];
    char what[16];
    uint64_t cycle;
};

constexpr std::size_t kCapacity = 1 << 20;
Raw g_entries[kCapacity];
std::atomic<std::size_t> g_count{0};
std::atomic<int> g_flag{0};

}  // namespace

void add(const char *who, const char *what, uint64_t cycle) noexcept {
    std::size_t i = g_count.fetch_add(1);
    if (i >= kCapacity) return;
    std::strncpy(g_entries[i].who, who, sizeof g_entries[i].who - 1);
    std::strncpy(g_entries[i].what, what, sizeof g_entries[i].what - 1);
    g_entries[i].cycle = cycle;
}

void setFlag(int value) noexcept { g_flag.store(value); }
int flag() noexcept { return g_flag.load(); }

std::vector<Entry> entries() {
    std::size_t n = std::min(g_count.load(), kCapacity);
    std::vector<Entry> out;
    out.reserve(n);
    for (std::size_t i = 0; i < n; ++i) out.push_back({g_entries[i].who, g_entries[i].what, g_entries[i].cycle});
    return out;
}

void clear() {
    std::memset(g_entries, 0, sizeof(Raw) * std::min(g_count.load(), kCapacity));
    g_count = 0;
    g_flag = 0;
}

}  // namespace journal
