// arguments.cpp -- the checks of arguments.hpp, driven by the generated command table.
#include "protocol/arguments.hpp"

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

namespace irp::protocol {
namespace {

std::span<const Arg> membersOf(const Arg &arg) { return {arg.members, arg.member_count}; }

std::string quoted(const char *name) { return std::string("'") + name + "'"; }

// "a, b or c"
std::string alternatives(const std::vector<std::string> &names) {
    std::string text;
    for (std::size_t i = 0; i < names.size(); ++i)
        text += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
    return text;
}

// One value against its Arg.  `label` names it in the messages ('priority'); `prefix` is what
// encloses it ("" at the top, "changes[2]: " in a list's entry).
Status checkValue(const Arg &arg, const nlohmann::json &value, const std::string &prefix, const std::string &label);

Status checkInteger(const Arg &arg, const nlohmann::json &value, const std::string &label) {
    if (!value.is_number_integer()) return Error{label + " must be " + arg.expected};
    // nlohmann keeps integers above 2^63 - 1 as unsigned; every integer argument is an int64.
    if (value.is_number_unsigned() &&
        value.get<uint64_t>() > static_cast<uint64_t>(std::numeric_limits<int64_t>::max()))
        return Error{label + " is out of range: at most " + std::to_string(std::numeric_limits<int64_t>::max())};
    const auto v = value.get<int64_t>();
    if ((arg.has_min && v < arg.min) || (arg.has_max && v > arg.max)) return Error{label + " must be " + arg.expected};
    return Ok{};
}

Status checkString(const Arg &arg, const nlohmann::json &value, const std::string &label) {
    if (!value.is_string()) return Error{label + " must be " + arg.expected};
    const auto length = static_cast<int64_t>(value.get_ref<const std::string &>().size());
    if ((arg.has_min && length < arg.min) || (arg.has_max && length > arg.max))
        return Error{label + " must be " + arg.expected};
    return Ok{};
}

// One entry of an ObjectList `list`: an object of its members only, with every required one and
// at least one of those marked one_of.  `at` names the entry: changes[2].
Status checkEntry(const Arg &list, const nlohmann::json &entry, const std::string &at) {
    const std::span<const Arg> members = membersOf(list);
    std::vector<std::string> names, one_of;
    std::string shape;
    for (const Arg &m : members) {
        names.emplace_back(m.name);
        if (m.one_of) one_of.emplace_back(m.name);
        shape += (shape.empty() ? "{" : ", ") + std::string(m.name) + (m.required ? "" : "?");
    }
    if (!entry.is_object()) return Error{at + " must be an object " + shape + "}"};
    for (const auto &[key, _] : entry.items()) {
        bool known = false;
        for (const Arg &m : members) known |= key == m.name;
        if (!known) {
            std::string list_of;
            for (const std::string &n : names) list_of += (list_of.empty() ? "" : ", ") + n;
            return Error{at + ": unknown member '" + key + "'; the members are " + list_of};
        }
    }
    std::string which;  // the entry's first required string, to name it: " (module 'cntr1')"
    bool given = false;
    for (const Arg &m : members) {
        auto found = entry.find(m.name);
        if (found == entry.end()) {
            if (m.required) return Error{at + ": " + quoted(m.name) + " is required: " + m.expected};
            continue;
        }
        if (Status st = checkValue(m, *found, at + ": ", quoted(m.name)); !st) return st;
        if (m.required && m.type == ArgType::String && which.empty())
            which = std::string(" (") + m.name + " '" + found->get<std::string>() + "')";
        given |= m.one_of;
    }
    if (!one_of.empty() && !given) return Error{at + which + " changes nothing; give " + alternatives(one_of)};
    return Ok{};
}

Status checkList(const Arg &arg, const nlohmann::json &value, const std::string &prefix, const std::string &label) {
    if (!value.is_array()) return Error{label + " must be " + arg.expected};
    const auto size = static_cast<int64_t>(value.size());
    if (arg.has_min && size < arg.min) return Error{label + " must be " + arg.expected};
    if (arg.has_max && size > arg.max)
        return Error{label + " holds more than " + std::to_string(arg.max) + " entries; it must be " + arg.expected};
    for (std::size_t i = 0; i < value.size(); ++i) {
        const std::string at = prefix + arg.name + "[" + std::to_string(i) + "]";
        Status st = arg.type == ArgType::ObjectList ? checkEntry(arg, value[i], at)
                                                    : checkValue(arg.members[0], value[i], "", at);
        if (!st) return st;
    }
    return Ok{};
}

Status checkValue(const Arg &arg, const nlohmann::json &value, const std::string &prefix, const std::string &label) {
    const std::string named = prefix + label;
    switch (arg.type) {
    case ArgType::String: return checkString(arg, value, named);
    case ArgType::Integer: return checkInteger(arg, value, named);
    case ArgType::Boolean:
        if (!value.is_boolean()) return Error{named + " must be " + arg.expected};
        return Ok{};
    case ArgType::Scalar:
        if (!value.is_number() && !value.is_boolean()) return Error{named + " must be " + arg.expected};
        return Ok{};
    case ArgType::StringList:
    case ArgType::ObjectList: return checkList(arg, value, prefix, named);
    }
    return Error{named + ": no check for its type"};
}

}  // namespace

Result<const Command *> findCommand(const std::string &name) {
    for (const Command &command : kCommands)
        if (name == command.name) return &command;
    return Error{"unknown command '" + name + "'; the commands are " + kCommandList};
}

Status checkArguments(const Command &command, const nlohmann::json &request) {
    for (const Arg &arg : std::span<const Arg>(command.args, command.arg_count)) {
        auto found = request.find(arg.name);
        // The argument is the error's field.
        const auto refused = [&](std::string message) {
            Error e{std::move(message)};
            e.place.field = arg.name;
            return e;
        };
        if (found == request.end()) {
            if (arg.required) return refused(quoted(arg.name) + " is required: " + arg.expected);
            continue;
        }
        if (Status st = checkValue(arg, *found, "", quoted(arg.name)); !st) return refused(st.error().message);
    }
    return Ok{};
}

}  // namespace irp::protocol
