// variable_write.cpp -- a leaf by its path; JSON value <-> the leaf's scalar bytes; channel::write.
#include "variables/variable_write.hpp"

#include <indurop/process.h>
#include <indurop/shared.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>

namespace irp::variables {
namespace {

using json = nlohmann::ordered_json;

template <class T>
LeafBytes bytesOf(T value) {
    LeafBytes b{};
    std::memcpy(b.data(), &value, sizeof value);
    return b;
}

template <class T>
T valueOf(const LeafBytes &b) {
    T v;
    std::memcpy(&v, b.data(), sizeof v);
    return v;
}

template <class T>
Result<LeafBytes> integral(const nlohmann::json &v, const std::string &path, const std::string &type) {
    if (v.is_boolean()) return bytesOf(static_cast<T>(v.get<bool>()));
    if (v.is_number_integer()) {
        if (v.is_number_unsigned()) {
            const auto u = v.get<uint64_t>();
            if (u <= static_cast<uint64_t>(std::numeric_limits<T>::max())) return bytesOf(static_cast<T>(u));
        } else {
            const auto s = v.get<int64_t>();
            if (s >= static_cast<int64_t>(std::numeric_limits<T>::min()) &&
                (s < 0 || static_cast<uint64_t>(s) <= static_cast<uint64_t>(std::numeric_limits<T>::max())))
                return bytesOf(static_cast<T>(s));
        }
        return Error{"'" + path + "' is " + type + ": " + v.dump() + " is out of its range " +
                     std::to_string(static_cast<int64_t>(std::numeric_limits<T>::min())) + ".." +
                     std::to_string(static_cast<uint64_t>(std::numeric_limits<T>::max()))};
    }
    return Error{"'" + path + "' is " + type + ": give an integer, not " + v.dump()};
}

// Calls fn(T{}) with the C++ type of the leaf's kind and size.
template <class Fn>
auto withType(const Leaf &leaf, Fn fn) -> decltype(fn(int8_t{})) {
    const uint32_t size = leaf.size;
    if (leaf.kind == "float") return size == 4 ? fn(float{}) : fn(double{});
    if (leaf.kind == "bool") return fn(bool{});
    if (leaf.kind == "unsigned") {
        if (size == 1) return fn(uint8_t{});
        if (size == 2) return fn(uint16_t{});
        if (size == 4) return fn(uint32_t{});
        return fn(uint64_t{});
    }
    if (size == 1) return fn(int8_t{});
    if (size == 2) return fn(int16_t{});
    if (size == 4) return fn(int32_t{});
    return fn(int64_t{});
}

}  // namespace

Result<Leaf> findLeaf(const nlohmann::json &layout, const std::string &path) {
    if (!layout.contains("leaves") || !layout.contains("scalars")) return Error{"the running layout cannot be read"};
    const nlohmann::json *found = nullptr;
    for (const auto &l : layout["leaves"])
        if (l.value("path", "") == path) found = &l;
    if (!found) {
        std::string members, hint;
        for (const auto &l : layout["leaves"]) {
            const std::string p = l.value("path", "");
            const bool member =
                p.size() > path.size() && p.rfind(path, 0) == 0 && (p[path.size()] == '.' || p[path.size()] == '[');
            if (member && members.size() < 200) members += (members.empty() ? "" : ", ") + p;
            if (p.rfind(path, 0) == 0 && hint.size() < 200) hint += (hint.empty() ? "" : ", ") + p;
        }
        if (!members.empty())
            return Error{"'" + path + "' is a struct or an array: give one of its members or elements (" + members +
                         ")"};
        return Error{
            "no variable '" + path + "' in the running layout" +
            (hint.empty() ? std::string("; GET /api/v1/variables lists them") : "; did you mean " + hint + "?")};
    }
    Leaf leaf;
    leaf.path = path;
    leaf.type = found->value("type", "");
    leaf.offset = found->value("offset", uint64_t{0});
    leaf.size = found->value("size", 0u);
    leaf.lock = found->value("lock", 0u);
    leaf.kind = layout["scalars"].contains(leaf.type) ? layout["scalars"][leaf.type].value("kind", "") : "";
    const bool sized = leaf.size == 1 || leaf.size == 2 || leaf.size == 4 || leaf.size == 8;
    if (leaf.kind.empty() || !sized || (leaf.kind == "float" && leaf.size < 4))
        return Error{"'" + path + "' is a " + leaf.type + ", which cannot be written from JSON"};
    return leaf;
}

Result<LeafBytes> encodeValue(const Leaf &leaf, const nlohmann::json &value) {
    const std::string &path = leaf.path;
    if (leaf.kind == "float") {
        if (!value.is_number()) return Error{"'" + path + "' is " + leaf.type + ": give a number, not " + value.dump()};
        const double d = value.get<double>();
        if (!std::isfinite(d)) return Error{"'" + path + "': the value must be finite"};
        return leaf.size == 4 ? bytesOf(static_cast<float>(d)) : bytesOf(d);
    }
    if (leaf.kind == "bool") {
        if (value.is_boolean()) return bytesOf(value.get<bool>());
        if (value.is_number_integer() && (value.get<int64_t>() == 0 || value.get<int64_t>() == 1))
            return bytesOf(value.get<int64_t>() == 1);
        return Error{"'" + path + "' is bool: give true or false, not " + value.dump()};
    }
    return withType(leaf, [&]<class T>(T) -> Result<LeafBytes> {
        if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) return integral<T>(value, path, leaf.type);
        return Error{"'" + path + "' cannot be written from JSON"};
    });
}

json decodeValue(const Leaf &leaf, const LeafBytes &bytes) {
    return withType(leaf, [&]<class T>(T) { return json(valueOf<T>(bytes)); });
}

LeafBytes readLeaf(const Leaf &leaf) noexcept {
    LeafBytes b{};
    const char *source = indurop_shared_data + leaf.offset;
    irp::shared::detail::readConsistent(leaf.lock,
                                        [&] { irp::shared::detail::atomicCopy(b.data(), source, leaf.size); });
    return b;
}

Status writeLeaf(const Leaf &leaf, const LeafBytes &bytes) {
    static std::mutex mutex;  // one handle, used by one thread at a time
    static channel::Handle handle;
    std::lock_guard lock(mutex);
    if (::write(handle, leaf.path.c_str(), leaf.size, bytes.data()) != static_cast<int>(leaf.size))
        return Error{std::string("cannot write '") + leaf.path + "': " + channel::lastError(handle)};
    return Ok{};
}

Result<json> writeByPath(const nlohmann::json &layout, const std::string &path, const nlohmann::json &value) {
    auto leaf = findLeaf(layout, path);
    if (!leaf) return leaf.error();
    auto bytes = encodeValue(*leaf, value);
    if (!bytes) return bytes.error();
    if (Status st = writeLeaf(*leaf, *bytes); !st) return st.error();
    return json{{"path", path}, {"value", decodeValue(*leaf, *bytes)}};
}

}  // namespace irp::variables
