// arguments.hpp -- a control request's arguments checked against the protocol's command table
// (protocol/command_table.hpp, generated from protocol/control.json): types, ranges, required
// members, list sizes, unknown members of list entries.  The messages name the argument and what
// it must be.  What a command does with its arguments is irpd/commands.cpp's.
#pragma once

#include <indurop/result.hpp>
#include "protocol/command_table.hpp"

#include <nlohmann/json.hpp>

#include <string>

namespace irp::protocol {

// The description of command `name`, or an Error listing the commands there are.
Result<const Command *> findCommand(const std::string &name);

// The arguments of `request` for `command` checked, or an Error naming the first one to fix.
// Members the command does not take are left alone at the top (a request also holds "id" and
// "cmd"); inside a list's entries they are refused.
Status checkArguments(const Command &command, const nlohmann::json &request);

}  // namespace irp::protocol
