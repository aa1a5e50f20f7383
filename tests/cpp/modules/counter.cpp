// counter.cpp -- counts its runs; writes "start v<version>" at start() and "stop v<version>
// runs=<n>" at stop() to the file named by its "journal" property.  Built twice (counter_v1,
// counter_v2): a hot reload that keeps it must show one start and a count that covers every
// period; one that replaces it must show the new version's start.
#include <indurop/indurop.h>

#include <cstdio>
#include <string>

namespace {
std::string journal;
unsigned long long runs = 0;

void note(const std::string &line) {
    if (FILE *f = std::fopen(journal.c_str(), "a")) {
        std::fprintf(f, "%s\n", line.c_str());
        std::fclose(f);
    }
}
}  // namespace

extern "C" void initialize(irp::Property const &p) { journal = p.get("journal", std::string_view("/dev/null")); }
void start() { note("start v" + std::to_string(COUNTER_VERSION)); }
void run() { ++runs; }
void stop() { note("stop v" + std::to_string(COUNTER_VERSION) + " runs=" + std::to_string(runs)); }
