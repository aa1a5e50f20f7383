// source_line.hpp -- an instruction's offset in a module's file mapped to its source line through
// the file's DWARF line table, by binutils' addr2line (a subprocess: run once, when a crash record
// is taken in at the next start, never in the crash handler).  Generated code that carries
// `#line 12 "main.st"` maps to main.st:12.  Modules are built with a line table
// (cmake/InduropModule.cmake: -g1 unless the build type has -g already).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

namespace irp::supervise {

// "main.st:12" / "Robot.cpp:240" (the file's name without its folder), or "" when it is not known:
// no such file, no line table (a stripped module), no addr2line, or it took longer than 5 s.
std::string sourceLine(const std::filesystem::path &image, uintptr_t offset);

}  // namespace irp::supervise
