// oc_modules.cpp -- thread modules of test_online_change, built against the layouts v1..v4:
//   OC_COUNTER   counts its runs in oc.counter and in itself; journals start and stop (runs=)
//   OC_ADDER     oc.added = oc.counter, every run
//   OC_RETYPED   oc.retyped += 1, whatever type the layout it was built against gives it
//   OC_MIRROR    oc.added = oc.proc_runs, every run (what the process module left for the next module)
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include <cstdio>
#include <string>

using namespace oc;

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
void start() { note("start"); }
void stop() { note("stop runs=" + std::to_string(runs)); }
void run() {
    ++runs;
#if defined(OC_COUNTER)
    counter += 1;
#elif defined(OC_ADDER)
    added = static_cast<double>(static_cast<uint64_t>(counter));
#elif defined(OC_MIRROR)
    added = static_cast<double>(static_cast<uint64_t>(proc_runs));
#elif defined(OC_RETYPED)
    retyped += 1;
#endif
}
