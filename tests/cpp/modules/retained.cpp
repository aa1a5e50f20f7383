// retained.cpp -- adds 1 to the uint64_t shared variable named by its property "count" every period
// (a path, resolved from the running layout: no build against the .glb), and writes the value it
// finds at initialize() to the file named by "journal": what the retain store (docs/retain.md)
// restored before any module's initialize().
#include <indurop/indurop.h>
#include <indurop/process.h>

#include <cstdint>
#include <cstdio>
#include <string>

namespace {
std::string path;
channel::Handle handle;
}  // namespace

extern "C" void initialize(irp::Property const &p) {
    path = p.get("count", std::string_view(""));
    uint64_t v = 0;
    const int got = ::read(handle, path.c_str(), sizeof v, &v);  // resolves the path once, before run()
    if (FILE *f = std::fopen(std::string(p.get("journal", std::string_view("/dev/null"))).c_str(), "a")) {
        std::fprintf(f, "initialize %s=%llu\n", path.c_str(),
                     got == sizeof v ? static_cast<unsigned long long>(v) : 0ull);
        std::fclose(f);
    }
}

void run() {
    uint64_t v = 0;
    if (::read(handle, path.c_str(), sizeof v, &v) != sizeof v) return;
    ++v;
    ::write(handle, path.c_str(), sizeof v, &v);
}
