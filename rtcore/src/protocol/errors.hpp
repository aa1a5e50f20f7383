// errors.hpp -- an Error as the control protocol sends it (protocol/control.json, "error"): its
// code, its message, and the fields of its place that are known (file, line, column, module,
// field), so that the agent and the web UI read the place instead of finding it in the text.
#pragma once

#include "protocol/limits.hpp"

#include <indurop/result.hpp>

#include <nlohmann/json.hpp>

#include <string_view>

namespace irp::protocol {

// An Error's default code (the SDK's result.hpp) is the spec's `refused`.
static_assert(std::string_view{kErrorRefused} == kRefused,
              "indurop/result.hpp: kErrorRefused is not protocol/control.json's refused");

// The place's known fields into `out` (an object).
inline void addPlace(nlohmann::ordered_json &out, const Place &place) {
    if (!place.file.empty()) out["file"] = place.file;
    if (place.line > 0) out["line"] = place.line;
    if (place.column > 0) out["column"] = place.column;
    if (!place.module.empty()) out["module"] = place.module;
    if (!place.field.empty()) out["field"] = place.field;
}

// The place's known fields as an object of their own (`status.last_restart.error_at`).
inline nlohmann::ordered_json placeJson(const Place &place) {
    nlohmann::ordered_json out = nlohmann::ordered_json::object();
    addPlace(out, place);
    return out;
}

// A place read back from such an object (the fields it lacks stay unknown).
template <class Json>
Place placeFrom(const Json &j) {
    if (!j.is_object()) return {};
    return Place{j.value("file", ""), j.value("line", 0), j.value("column", 0), j.value("module", ""),
                 j.value("field", "")};
}

// {"code", "message", and the place's fields}: a refusal's "error".
inline nlohmann::ordered_json errorJson(const Error &error) {
    nlohmann::ordered_json out{{"code", error.code}, {"message", error.message}};
    addPlace(out, error.place);
    return out;
}

// {"message", and the place's fields}: one entry of `check`'s "problems".
inline nlohmann::ordered_json problemJson(const Error &error) {
    nlohmann::ordered_json out{{"message", error.message}};
    addPlace(out, error.place);
    return out;
}

}  // namespace irp::protocol
