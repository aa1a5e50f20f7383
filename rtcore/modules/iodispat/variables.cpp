// variables.cpp -- scalar leaves of the layout, resolved by path, read and written as doubles.
#include "variables.hpp"

#include "codec.hpp"

#include <indurop/shared.h>

#include <nlohmann/json.hpp>

#include <cstring>
#include <stdexcept>

namespace irp::iodispat {

VarTable::VarTable() {
    const std::string text = irp::shared::layoutText();
    if (text.empty())
        throw std::runtime_error(
            "no shared-variable segment: the set needs a <layout> (the .glb with the variables ioconfig.xml names)");
    const auto doc = nlohmann::json::parse(text);
    std::unordered_map<std::string, Leaf> scalars;
    for (const auto &[name, s] : doc.at("scalars").items()) {
        const std::string kind = s.at("kind").get<std::string>();
        Leaf leaf{ScalarKind::Float, s.at("size").get<int>()};
        if (kind == "signed")
            leaf.kind = ScalarKind::Signed;
        else if (kind == "unsigned")
            leaf.kind = ScalarKind::Unsigned;
        else if (kind == "bool")
            leaf.kind = ScalarKind::Bool;
        else if (kind != "float")
            continue;  // a kind this module does not convert: its leaves stay unmappable
        if (leaf.size != 1 && leaf.size != 2 && leaf.size != 4 && leaf.size != 8) continue;
        if (leaf.kind == ScalarKind::Float && leaf.size != 4 && leaf.size != 8) continue;
        scalars.emplace(name, leaf);
    }
    for (const auto &l : doc.at("leaves")) {
        auto it = scalars.find(l.at("type").get<std::string>());
        if (it != scalars.end()) leaves_.emplace(l.at("path").get<std::string>(), it->second);
    }
    if (doc.contains("namespaces"))
        for (const auto &n : doc.at("namespaces")) namespaces_.push_back(n.get<std::string>());
}

VarRef VarTable::resolve(channel::Handle &handle, const std::string &written, const std::string &where) const {
    std::string path;  // "::" between namespace parts and the name -> "."
    for (std::size_t i = 0; i < written.size(); ++i) {
        const bool scope = written[i] == ':' && i + 1 < written.size() && written[i + 1] == ':';
        path += scope ? '.' : written[i];
        i += scope ? 1 : 0;
    }
    auto found = leaves_.find(path);
    if (found == leaves_.end()) {
        std::vector<std::string> matches;
        for (const std::string &ns : namespaces_)
            if (leaves_.count(ns + "." + path)) matches.push_back(ns + "." + path);
        if (matches.size() > 1)
            throw std::runtime_error(where + ": path '" + written + "' is ambiguous (" + matches[0] + ", " +
                                     matches[1] + "): write the namespace");
        if (matches.size() == 1) {
            path = matches[0];
            found = leaves_.find(path);
        }
    }
    if (found == leaves_.end()) {
        // A struct or an array, or nothing at all?
        auto below = [](const std::string &leaf, const std::string &prefix) {
            return leaf.size() > prefix.size() && leaf.compare(0, prefix.size(), prefix) == 0 &&
                   (leaf[prefix.size()] == '.' || leaf[prefix.size()] == '[');
        };
        std::string example;  // the first scalar inside it, in path order
        for (const auto &[leaf, kind] : leaves_) {
            bool inside = below(leaf, path);
            for (const std::string &ns : namespaces_) inside = inside || below(leaf, ns + "." + path);
            if (inside && (example.empty() || leaf < example)) example = leaf;
        }
        if (!example.empty())
            throw std::runtime_error(where + ": path '" + written +
                                     "' is a struct or an array: map one scalar, e.g. '" + example + "'");
        throw std::runtime_error(where + ": no scalar shared variable has the path '" + written +
                                 "' in the running layout");
    }
    VarRef v{path, found->second.kind, found->second.size};
    double scratch;
    if (!readVar(handle, v, scratch))
        throw std::runtime_error(where + ": path '" + written + "': " + channel::lastError(handle));
    return v;
}

bool readVar(channel::Handle &handle, const VarRef &v, double &out) noexcept {
    alignas(8) unsigned char b[8];
    if (read(handle, v.path.c_str(), static_cast<std::size_t>(v.size), b) != v.size) return false;
    switch (v.kind) {
    case ScalarKind::Bool: out = b[0] ? 1 : 0; return true;
    case ScalarKind::Float:
        if (v.size == 4) {
            float f;
            std::memcpy(&f, b, 4);
            out = f;
        } else {
            double d;
            std::memcpy(&d, b, 8);
            out = d;
        }
        return true;
    case ScalarKind::Signed:
        switch (v.size) {
        case 1: {
            int8_t x;
            std::memcpy(&x, b, 1);
            out = x;
            return true;
        }
        case 2: {
            int16_t x;
            std::memcpy(&x, b, 2);
            out = x;
            return true;
        }
        case 4: {
            int32_t x;
            std::memcpy(&x, b, 4);
            out = x;
            return true;
        }
        default: {
            int64_t x;
            std::memcpy(&x, b, 8);
            out = static_cast<double>(x);
            return true;
        }
        }
    case ScalarKind::Unsigned:
        switch (v.size) {
        case 1: {
            uint8_t x;
            std::memcpy(&x, b, 1);
            out = x;
            return true;
        }
        case 2: {
            uint16_t x;
            std::memcpy(&x, b, 2);
            out = x;
            return true;
        }
        case 4: {
            uint32_t x;
            std::memcpy(&x, b, 4);
            out = x;
            return true;
        }
        default: {
            uint64_t x;
            std::memcpy(&x, b, 8);
            out = static_cast<double>(x);
            return true;
        }
        }
    }
    return false;
}

bool writeVar(channel::Handle &handle, const VarRef &v, double value) noexcept {
    alignas(8) unsigned char b[8] = {};
    switch (v.kind) {
    case ScalarKind::Bool: b[0] = value != 0 && value == value ? 1 : 0; break;
    case ScalarKind::Float:
        if (v.size == 4) {
            const float f = static_cast<float>(value);
            std::memcpy(b, &f, 4);
        } else
            std::memcpy(b, &value, 8);
        break;
    case ScalarKind::Signed:
        switch (v.size) {
        case 1: {
            const auto x = static_cast<int8_t>(clampRound(value, -128, 127));
            std::memcpy(b, &x, 1);
            break;
        }
        case 2: {
            const auto x = static_cast<int16_t>(clampRound(value, -32768, 32767));
            std::memcpy(b, &x, 2);
            break;
        }
        case 4: {
            const auto x = static_cast<int32_t>(clampRound(value, -2147483648.0, 2147483647.0));
            std::memcpy(b, &x, 4);
            break;
        }
        default: {
            const auto x = static_cast<int64_t>(clampRound(value, -9223372036854775808.0, 9223372036854774784.0));
            std::memcpy(b, &x, 8);
            break;
        }
        }
        break;
    case ScalarKind::Unsigned:
        switch (v.size) {
        case 1: {
            const auto x = static_cast<uint8_t>(clampRound(value, 0, 255));
            std::memcpy(b, &x, 1);
            break;
        }
        case 2: {
            const auto x = static_cast<uint16_t>(clampRound(value, 0, 65535));
            std::memcpy(b, &x, 2);
            break;
        }
        case 4: {
            const auto x = static_cast<uint32_t>(clampRound(value, 0, 4294967295.0));
            std::memcpy(b, &x, 4);
            break;
        }
        default: {
            const auto x = static_cast<uint64_t>(clampRound(value, 0, 18446744073709549568.0));
            std::memcpy(b, &x, 8);
            break;
        }
        }
        break;
    }
    return write(handle, v.path.c_str(), static_cast<std::size_t>(v.size), b) == v.size;
}

}  // namespace irp::iodispat
