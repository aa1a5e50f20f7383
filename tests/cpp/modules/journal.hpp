// journal.hpp -- a shared record of what fixture modules did, in the order they did it.  The
// fixture modules and the test executables link the same libtest_journal.so, so a test reads
// directly what the modules it loaded wrote.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace journal {

struct Entry {
    std::string who;
    std::string what;  // "initialize", "start", "run", "stop", ...
    uint64_t cycle;    // irp::cycle().count for runs
};

void add(const char *who, const char *what, uint64_t cycle = 0) noexcept;
// A flag shared by the fixture modules of one process (an event source and its handler).
void setFlag(int value) noexcept;
int flag() noexcept;
std::vector<Entry> entries();
void clear();

}  // namespace journal
