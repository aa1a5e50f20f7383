// module_set.hpp -- all the modules of one set, loaded and taken through their lifecycle together.
//
// The thread modules of a set (periodic and sporadic); process modules are the process
// supervisor's, and have no entry here.  initialize and start go in file order; a failure stops
// the modules already started (in reverse order) and nothing is dispatched.
#pragma once

#include <indurop/result.hpp>
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

    // The thread module at set index i, or nullptr for a process module.
    ThreadModule *module(std::size_t i) const { return modules_[i].get(); }
    std::size_t size() const { return modules_.size(); }

private:
    std::vector<std::unique_ptr<ThreadModule>> modules_;
};

}  // namespace irp::hosts
