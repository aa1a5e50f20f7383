// variable_write.hpp -- writing one shared variable by its path, for irpd's control thread (the
// agent's PUT /variables/{path}): the JSON value is checked against the leaf's type in the layout
// and written under the variable's lock through libindurop's path access, as a process would.
#pragma once

#include <indurop/result.hpp>

#include <nlohmann/json.hpp>

#include <string>

namespace irp::variables {

// layout: the running layout.json, parsed once.  Returns {"path", "value"} (the value as stored), or an
// Error naming what to fix: unknown path (with a hint), a value of the wrong type, out of range.
Result<nlohmann::ordered_json> writeByPath(const nlohmann::json &layout, const std::string &path,
                                           const nlohmann::json &value);

}  // namespace irp::variables
