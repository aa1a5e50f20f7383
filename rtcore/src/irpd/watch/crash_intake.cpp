// crash_intake.cpp -- the previous run's crash record turned into an event and an exclusion;
// see crash_intake.hpp.
#include "irpd/watch/crash_intake.hpp"

#include "irpd/say.hpp"

#include <optional>

namespace irp::watch {

std::string canonicalSet(const std::filesystem::path &xml) {
    std::error_code ec;
    std::filesystem::path p = std::filesystem::weakly_canonical(xml, ec);
    return (ec ? std::filesystem::absolute(xml) : p).string();
}

void takeInCrash(supervise::CrashState &crash, const config::SetSpec &starting, events::EventLog &events) {
    const auto &fresh = crash.fresh();
    if (!fresh) return;
    std::string consequence;
    if (fresh->module.empty()) {
        const std::string why = fresh->cause();
        consequence = why == "watchdog" ? "; no dispatcher was stuck in a module, so none is left out"
                      : why == "signal" ? "; a signal sent to the process blames no module, so none is left out"
                                        : "; no module's code was running, so none is left out";
    } else {
        std::optional<config::SetSpec> other;
        const config::SetSpec *set = &starting;
        if (fresh->set != canonicalSet(starting.xml_path)) {
            if (auto parsed = config::parseModuleXml(fresh->set)) other = std::move(*parsed);
            set = other ? &*other : nullptr;
        }
        const config::ModuleSpec *culprit = nullptr;
        if (set)
            for (const config::ModuleSpec &m : set->modules)
                if (m.name == fresh->module) culprit = &m;
        if (culprit && culprit->on_crash == config::CrashPolicy::Restart) {
            consequence = "; it runs again (<on_crash>restart</on_crash>)";
        } else if (Status st = crash.exclude(fresh->set, fresh->module); !st) {
            consequence = "; could not record that it is left out: " + st.error().message;
        } else {
            consequence = "; left out of that set (<on_crash>exclude</on_crash>) until it is enabled again or the "
                          "record is cleared (clear_crash)";
        }
    }
    events.add("crash", fresh->module, fresh->describe() + consequence);
    daemon::say("the previous run ended by a crash: " + fresh->describe() + consequence);
}

}  // namespace irp::watch
