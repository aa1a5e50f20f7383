// crash_intake.hpp -- the crash that ended irpd's previous run, taken in at start
// (docs/supervision.md): a "crash" event, and the module whose code was running left out of its
// set from now on when its <on_crash> says exclude (the default).
#pragma once

#include "config/module_xml.hpp"
#include "events/event_log.hpp"
#include "supervise/crash_record.hpp"

#include <filesystem>
#include <string>

namespace irp::watch {

// A set as crash records name it: its module.xml's canonical path.
std::string canonicalSet(const std::filesystem::path &xml);

// Takes in crash.fresh(), if any: the event, and the exclusion of its module unless its
// <on_crash> is restart (the set's module.xml is read again for that when it is not `starting`).
// Says on irpd's log what it did.
void takeInCrash(supervise::CrashState &crash, const config::SetSpec &starting, events::EventLog &events);

}  // namespace irp::watch
