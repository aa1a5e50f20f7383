// module_set.cpp -- loading and lifecycle of a whole set.
#include "hosts/module_set.hpp"

namespace irp::hosts {

std::string unsupportedReason(const config::ModuleSpec &spec) {
    using config::ModuleType;
    using config::OperationType;
    if (spec.type == ModuleType::Process)
        return std::string(config::toString(spec.operation)) + " process modules are not run by this version of irpd";
    if (spec.operation == OperationType::Sporadic) return "sporadic thread modules are not run by this version of irpd";
    if (spec.operation == OperationType::NonReal) return "non-real thread modules are not run by this version of irpd";
    return "";
}

Result<std::unique_ptr<ModuleSet>> ModuleSet::load(const config::SetSpec &set, const char *layout_hash) {
    auto loaded = std::make_unique<ModuleSet>();
    for (const config::ModuleSpec &spec : set.modules) {
        std::string reason = unsupportedReason(spec);
        if (!reason.empty()) {
            loaded->modules_.push_back(nullptr);
            loaded->skip_reasons_.push_back(std::move(reason));
            continue;
        }
        auto module = ThreadModule::load(spec, layout_hash);
        if (!module) return module.error();
        loaded->modules_.push_back(std::move(*module));
        loaded->skip_reasons_.emplace_back();
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

} // namespace irp::hosts
