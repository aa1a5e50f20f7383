// events.cpp -- an event source and its sporadic handler, to check when the event handler fires.
//   EVENT_SOURCE: periodic; raises the journal's flag in the cycles listed in property "at"
//                 (e.g. "7 300 301"), journaling each raise.
//   EVENT_HANDLER: sporadic thread; condition() is the flag; run() journals the cycle and lowers it.
#include "journal.hpp"

#include <indurop/indurop.h>

#include <set>
#include <sstream>

#if defined(EVENT_SOURCE)
namespace {
std::set<uint64_t> at;
}
extern "C" void initialize(irp::Property const &p) {
    std::istringstream in(p.get("at"));
    for (uint64_t c; in >> c;) at.insert(c);
}
void run() {
    const uint64_t c = irp::cycle().count;
    if (at.count(c)) {
        journal::setFlag(1);
        journal::add("source", "raise", c);
    }
}
#elif defined(EVENT_HANDLER)
extern "C" int condition() { return journal::flag(); }
void run() {
    journal::add("handler", "run", irp::cycle().count);
    journal::setFlag(0);
}
#else
#error "events.cpp needs EVENT_SOURCE or EVENT_HANDLER"
#endif
