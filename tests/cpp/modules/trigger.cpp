// trigger.cpp -- modules that misbehave on purpose once a file exists (property "trigger": its
// path), so that a test decides exactly when: TRIGGER_STALL blocks in run() for good (a hung
// module: the systemd watchdog's case), TRIGGER_CRASH dereferences a null pointer in run() (a
// thread module's segfault: the crash record's case; with TRIGGER_LINE_DIRECTIVE that line is
// `#line 12 "main.st"`, as generated Structured Text carries it).  Until then they count their runs.
#include <indurop/indurop.h>

#include <unistd.h>

#include <string>

namespace {
std::string trigger;
bool fired() { return !trigger.empty() && access(trigger.c_str(), F_OK) == 0; }
}  // namespace

extern "C" void initialize(irp::Property const &p) { trigger = p.get("trigger"); }

void run() {
    if (!fired()) return;
#if defined(TRIGGER_STALL)
    for (;;) sleep(1000);
#elif defined(TRIGGER_CRASH)
    volatile int *nowhere = nullptr;
#if defined(TRIGGER_LINE_DIRECTIVE)
#line 12 "main.st"
    *nowhere = 1;  // main.st:12
#else
    *nowhere = 1;  // the crash line
#endif
#else
#error "trigger.cpp needs TRIGGER_STALL or TRIGGER_CRASH"
#endif
}
