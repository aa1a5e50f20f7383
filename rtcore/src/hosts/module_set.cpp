// module_set.cpp -- loading and lifecycle of a whole set.
#include "hosts/module_set.hpp"

namespace irp::hosts {

Result<std::unique_ptr<ModuleSet>> ModuleSet::load(const config::SetSpec &set, const char *layout_hash) {
    auto loaded = std::make_unique<ModuleSet>();
    for (const config::ModuleSpec &spec : set.modules) {
        if (spec.type == config::ModuleType::Process) {  // the process supervisor's
            loaded->modules_.push_back(nullptr);
            continue;
        }
        if (spec.operation == config::OperationType::NonReal)
            return config::errorAbout(spec,
                                      "a non-real module runs in the time left over as a process: set "
                                      "<moduletype>process</moduletype>",
                                      "moduletype");
        auto module = ThreadModule::load(spec, layout_hash);
        if (!module) return module.error();
        if (spec.operation == config::OperationType::Sporadic && !(*module)->hasCondition())
            return config::errorAbout(spec,
                                      "a sporadic thread module needs condition() (extern \"C\" int condition(), or "
                                      "INDUROP_MODULE(condition = ...)), which the event handler calls every basic "
                                      "period");
        loaded->modules_.push_back(std::move(*module));
    }
    return loaded;
}

Status ModuleSet::initializeAll() {
    for (auto &m : modules_)
        if (m)
            if (Status s = m->initialize(); !s) return s;
    return Ok{};
}

Status ModuleSet::startAll() {
    for (std::size_t i = 0; i < modules_.size(); ++i) {
        if (!modules_[i]) continue;
        if (Status s = modules_[i]->start(); !s) {
            for (std::size_t j = i; j-- > 0;)
                if (modules_[j]) (void)modules_[j]->stop();
            return s;
        }
    }
    return Ok{};
}

std::vector<std::string> ModuleSet::stopAll() {
    std::vector<std::string> errors;
    for (auto &m : modules_)
        if (m)
            if (Status s = m->stop(); !s) errors.push_back(s.error().message);
    return errors;
}

}  // namespace irp::hosts
