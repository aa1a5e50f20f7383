// module_set.hpp -- all the modules of one set, loaded and taken through their lifecycle together.
//
// This irpd runs periodic thread modules; the other kinds of module.xml (process, sporadic,
// non-real) are kept in the schedule but not run, and each one is reported as skipped with the
// reason.  initialize and start go in file order; a failure stops the modules already started
// (in reverse order) and nothing is dispatched.
#pragma once

#include "common/result.hpp"
#include "config/module_xml.hpp"
#include "hosts/thread_module.hpp"

#include <memory>
#include <string>
#include <vector>

namespace irp::hosts {

class ModuleSet {
public:
    // Loads every runnable module of the set; the first failure is returned and nothing stays loaded.
    static Result<std::unique_ptr<ModuleSet>> load(const config::SetSpec &set, const char *layout_hash = nullptr);

    Status initializeAll();
    Status startAll();
    // stop() of every started module, in file order; returns the messages of those that threw.
    std::vector<std::string> stopAll();

    // The module at set index i, or nullptr when it is not run by this irpd.
    ThreadModule *module(std::size_t i) const { return modules_[i].get(); }
    std::size_t size() const { return modules_.size(); }
    // Why module i is not run ("" when it is).
    const std::string &skipReason(std::size_t i) const { return skip_reasons_[i]; }

private:
    std::vector<std::unique_ptr<ThreadModule>> modules_;
    std::vector<std::string> skip_reasons_;
};

// "" if this irpd runs such a module, else why not.
std::string unsupportedReason(const config::ModuleSpec &spec);

} // namespace irp::hosts
