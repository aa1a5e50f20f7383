// runtime.hpp -- the host side of libindurop: what irpd uses to feed modules their cycle and to
// drain the lines modules wrote with irp::printf.  Not installed for modules.
#pragma once

#include <indurop/indurop.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <set>
#include <vector>

namespace irp::runtime {

// Sets what irp::cycle() returns on the calling thread (the dispatcher, before each slot).
void setCycle(const Cycle &cycle) noexcept;

// Capacity and line size of the irp::printf ring.
inline constexpr std::size_t kLogLines = 1024;
inline constexpr std::size_t kLogLineBytes = 240;

// Hands every queued line to sink, oldest first; returns how many.  Call from one thread only.
std::size_t drainLog(const std::function<void(std::string_view)> &sink);

// Lines irp::printf dropped because the ring was full, since the process started.
uint64_t droppedLogLines() noexcept;

// Shared functions: the module whose initialize()/start() runs now on this thread (so that its
// exports are recorded as its own), and dropping a module's exports when it is unloaded.  The
// instance tells two loads of a module of the same name apart (a hot reload's old and new one).
void setCurrentModule(const std::string &name, uint64_t instance = 0);
void dropFunctionsOf(uint64_t instance);
std::size_t exportedFunctions();

// Every export, sorted by name: what irpd publishes as the function table for process modules.
struct FunctionExport {
    std::string name;
    std::string signature;  // typeid(R(A...)).name()
    std::string owner;      // the module whose initialize()/start() exported it ("" if none)
    detail::AnyFunction fn = nullptr;
    detail::CallShape shape;
};
std::vector<FunctionExport> functionExports();  // the newest export of each name
// The names a module instance exports, and the instances that found one of them (findFunction in
// their initialize() or start(): they may hold its pointer).
std::vector<std::string> exportsOf(uint64_t instance);
std::set<uint64_t> importersOf(uint64_t instance);
// FNV-1a 64 of a typeid name: how a call request names its signature (<indurop/control.h>).
uint64_t signatureHash(const char *signature) noexcept;

}  // namespace irp::runtime

struct indurop_segment_header;
namespace irp::shared {
// irpd: the segment it created is this process's segment (null: none any more).
void adopt(const indurop_segment_header *header) noexcept;
const indurop_segment_header *segmentHeader() noexcept;
}  // namespace irp::shared
