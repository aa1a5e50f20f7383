// module_code.cpp -- the table of loaded modules' address ranges; see module_code.hpp.
#include "supervise/module_code.hpp"

#include <dlfcn.h>
#include <link.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>
#include <mutex>

namespace irp::supervise {
namespace {

// One loaded module: [start, end) covers every PT_LOAD segment of its file; `end` 0 marks a free
// entry, and is stored last (release) so that the handler never sees half-written fields.
struct Entry {
    std::atomic<uintptr_t> start{0}, end{0};
    uintptr_t base = 0;  // the load bias: an address in the file is base + its p_vaddr
    char module[64] = {};
    char image[512] = {};
};
constexpr std::size_t kEntries = 256;  // modules loaded at once, a hot reload's two generations included
Entry g_entries[kEntries];
std::mutex g_writers;  // registrations (the main thread; tests may load from others)

struct Span {
    uintptr_t base = 0, start = UINTPTR_MAX, end = 0;
    bool found = false;
};

}  // namespace

int registerModuleCode(void *handle, const std::string &module, const std::string &image) {
    link_map *map = nullptr;
    if (!handle || dlinfo(handle, RTLD_DI_LINKMAP, &map) != 0 || !map) return -1;
    Span span;
    span.base = map->l_addr;
    // The segments of the object loaded at that bias (dl_iterate_phdr names them by their base).
    dl_iterate_phdr(
        [](dl_phdr_info *info, std::size_t, void *data) {
            auto *s = static_cast<Span *>(data);
            if (info->dlpi_addr != s->base || s->found) return 0;
            for (int i = 0; i < info->dlpi_phnum; ++i) {
                const ElfW(Phdr) &ph = info->dlpi_phdr[i];
                if (ph.p_type != PT_LOAD) continue;
                s->start = std::min<uintptr_t>(s->start, info->dlpi_addr + ph.p_vaddr);
                s->end = std::max<uintptr_t>(s->end, info->dlpi_addr + ph.p_vaddr + ph.p_memsz);
            }
            s->found = s->end > s->start;
            return s->found ? 1 : 0;
        },
        &span);
    if (!span.found) return -1;
    std::lock_guard lock(g_writers);
    for (std::size_t i = 0; i < kEntries; ++i) {
        Entry &e = g_entries[i];
        if (e.end.load(std::memory_order_relaxed)) continue;
        e.start.store(span.start, std::memory_order_relaxed);
        e.base = span.base;
        std::snprintf(e.module, sizeof e.module, "%s", module.c_str());
        std::snprintf(e.image, sizeof e.image, "%s", image.c_str());
        e.end.store(span.end, std::memory_order_release);
        return static_cast<int>(i);
    }
    return -1;
}

void unregisterModuleCode(int entry) noexcept {
    if (entry < 0 || static_cast<std::size_t>(entry) >= kEntries) return;
    std::lock_guard lock(g_writers);
    g_entries[entry].end.store(0, std::memory_order_release);
}

bool findModuleCode(uintptr_t pc, CodeLocation &out) noexcept {
    for (Entry &e : g_entries) {
        const uintptr_t end = e.end.load(std::memory_order_acquire);
        if (!end || pc < e.start.load(std::memory_order_relaxed) || pc >= end) continue;
        std::memcpy(out.module, e.module, sizeof out.module);
        std::memcpy(out.image, e.image, sizeof out.image);
        out.offset = pc - e.base;
        return true;
    }
    return false;
}

}  // namespace irp::supervise
