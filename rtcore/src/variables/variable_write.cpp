// variable_write.cpp -- JSON value -> the leaf's scalar type -> channel::write.
#include "variables/variable_write.hpp"

#include <indurop/process.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>

namespace irp::variables {
namespace {

using json = nlohmann::ordered_json;

template <class T>
Result<T> integral(const nlohmann::json &v, const std::string &path, const std::string &type) {
    if (v.is_boolean()) return static_cast<T>(v.get<bool>());
    if (v.is_number_integer()) {
        if (v.is_number_unsigned()) {
            const auto u = v.get<uint64_t>();
            if (u <= static_cast<uint64_t>(std::numeric_limits<T>::max())) return static_cast<T>(u);
        } else {
            const auto s = v.get<int64_t>();
            if (s >= static_cast<int64_t>(std::numeric_limits<T>::min()) &&
                (s < 0 || static_cast<uint64_t>(s) <= static_cast<uint64_t>(std::numeric_limits<T>::max())))
                return static_cast<T>(s);
        }
        return Error{"'" + path + "' is " + type + ": " + v.dump() + " is out of its range " +
                     std::to_string(static_cast<int64_t>(std::numeric_limits<T>::min())) + ".." +
                     std::to_string(static_cast<uint64_t>(std::numeric_limits<T>::max()))};
    }
    return Error{"'" + path + "' is " + type + ": give an integer, not " + v.dump()};
}

template <class T>
Result<json> store(const std::string &path, T value) {
    static std::mutex mutex;  // one handle, used by one thread at a time
    static channel::Handle handle;
    std::lock_guard lock(mutex);
    if (::write(handle, path.c_str(), sizeof value, &value) != static_cast<int>(sizeof value))
        return Error{std::string("cannot write '") + path + "': " + channel::lastError(handle)};
    return json{{"path", path}, {"value", value}};
}

}  // namespace

Result<json> writeByPath(const nlohmann::json &layout, const std::string &path, const nlohmann::json &value) {
    if (!layout.contains("leaves") || !layout.contains("scalars")) return Error{"the running layout cannot be read"};
    const nlohmann::json *leaf = nullptr;
    for (const auto &l : layout["leaves"])
        if (l.value("path", "") == path) leaf = &l;
    if (!leaf) {
        std::string hint;
        for (const auto &l : layout["leaves"]) {
            const std::string p = l.value("path", "");
            if (p.rfind(path, 0) == 0 && hint.size() < 200) hint += (hint.empty() ? "" : ", ") + p;
        }
        return Error{
            "no variable '" + path + "' in the running layout" +
            (hint.empty() ? std::string("; GET /api/v1/variables lists them") : "; did you mean " + hint + "?")};
    }
    const std::string type = leaf->value("type", "");
    const auto size = leaf->value("size", 0);
    const std::string kind = layout["scalars"].contains(type) ? layout["scalars"][type].value("kind", "") : "";
    if (kind == "float") {
        if (!value.is_number()) return Error{"'" + path + "' is " + type + ": give a number, not " + value.dump()};
        const double d = value.get<double>();
        if (!std::isfinite(d)) return Error{"'" + path + "': the value must be finite"};
        if (size == 4) return store(path, static_cast<float>(d));
        return store(path, d);
    }
    if (kind == "bool") {
        if (value.is_boolean()) return store(path, value.get<bool>());
        if (value.is_number_integer() && (value.get<int64_t>() == 0 || value.get<int64_t>() == 1))
            return store(path, value.get<int64_t>() == 1);
        return Error{"'" + path + "' is bool: give true or false, not " + value.dump()};
    }
    auto write = [&]<class T>(T) -> Result<json> {
        auto v = integral<T>(value, path, type);
        if (!v) return v.error();
        return store(path, *v);
    };
    if (kind == "signed" || kind == "char") {
        if (size == 1) return write(int8_t{});
        if (size == 2) return write(int16_t{});
        if (size == 4) return write(int32_t{});
        if (size == 8) return write(int64_t{});
    }
    if (kind == "unsigned") {
        if (size == 1) return write(uint8_t{});
        if (size == 2) return write(uint16_t{});
        if (size == 4) return write(uint32_t{});
        if (size == 8) return write(uint64_t{});
    }
    return Error{"'" + path + "' is a " + type + ", which cannot be written from JSON"};
}

}  // namespace irp::variables
