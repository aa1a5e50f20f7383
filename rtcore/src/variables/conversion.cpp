// conversion.cpp -- layout.json's planned conversions, checked, and run at the swap.
#include "variables/conversion.hpp"

#include <indurop/shared.h>

#include <nlohmann/json.hpp>

#include <atomic>
#include <cstring>

namespace irp::variables {
namespace {

bool parseCode(const std::string &text, ScalarCode &out) {
    if (text.size() != 2 || std::string("sufb").find(text[0]) == std::string::npos) return false;
    out.kind = text[0];
    out.size = static_cast<uint8_t>(text[1] - '0');
    if (out.kind == 'b') return out.size == 1;
    if (out.kind == 'f') return out.size == 4 || out.size == 8;
    return out.size == 1 || out.size == 2 || out.size == 4 || out.size == 8;
}

// [first, last byte + 1) of a copy's side inside [offset, offset + size), its scalars apart (so that
// a copy's count is bounded by its variable's size: the swap's work stays as small as the data)?
bool inside(uint64_t at, uint64_t count, uint64_t stride, uint8_t width, const layouts::Variable &v) {
    if (count == 0 || at < v.offset || (count > 1 && stride < width)) return false;
    const unsigned __int128 end =
        static_cast<unsigned __int128>(at) + (count - 1) * static_cast<unsigned __int128>(stride) + width;
    return end <= v.offset + v.size;
}

template <class T>
T load(const char *p) {
    T v;
    std::memcpy(&v, p, sizeof v);
    return v;
}

template <class T>
void store(char *p, T v) {
    std::memcpy(p, &v, sizeof v);
}

template <class T>
void storeAs(char *p, const ScalarCode &to, T v) {
    switch (to.kind) {
    case 'b': return store<bool>(p, v != T{});
    case 'f': return to.size == 4 ? store<float>(p, static_cast<float>(v)) : store<double>(p, static_cast<double>(v));
    case 's':
        switch (to.size) {
        case 1: return store<int8_t>(p, static_cast<int8_t>(v));
        case 2: return store<int16_t>(p, static_cast<int16_t>(v));
        case 4: return store<int32_t>(p, static_cast<int32_t>(v));
        default: return store<int64_t>(p, static_cast<int64_t>(v));
        }
    default:
        switch (to.size) {
        case 1: return store<uint8_t>(p, static_cast<uint8_t>(v));
        case 2: return store<uint16_t>(p, static_cast<uint16_t>(v));
        case 4: return store<uint32_t>(p, static_cast<uint32_t>(v));
        default: return store<uint64_t>(p, static_cast<uint64_t>(v));
        }
    }
}

void convertOne(const char *from, const ScalarCode &f, char *to, const ScalarCode &t) {
    switch (f.kind) {
    case 'b': return storeAs<bool>(to, t, load<bool>(from) ? true : false);
    case 'f': return storeAs<double>(to, t, f.size == 4 ? double{load<float>(from)} : load<double>(from));
    case 's': {
        const int64_t v = f.size == 1   ? load<int8_t>(from)
                          : f.size == 2 ? load<int16_t>(from)
                          : f.size == 4 ? load<int32_t>(from)
                                        : load<int64_t>(from);
        return storeAs<int64_t>(to, t, v);
    }
    default: {
        const uint64_t v = f.size == 1   ? load<uint8_t>(from)
                           : f.size == 2 ? load<uint16_t>(from)
                           : f.size == 4 ? load<uint32_t>(from)
                                         : load<uint64_t>(from);
        return storeAs<uint64_t>(to, t, v);
    }
    }
}

}  // namespace

Result<Conversions> conversionsOf(const Layout &next, const layouts::Model &running,
                                  const std::vector<layouts::Moved> &moved) {
    Conversions out;
    if (moved.empty()) return out;
    const std::string file = next.path.string();
    const auto bad = [&](const std::string &path, const std::string &what) {
        return fileError(file, "the conversion of variable '" + path + "' " + what +
                                   ": compile the set's .glb files again with glbc --previous (the running layout)");
    };
    nlohmann::json changes;
    try {
        changes = nlohmann::json::parse(next.text).value("changes", nlohmann::json::object());
    } catch (const nlohmann::json::exception &) {
        return out;  // readLayout parsed it: cannot happen
    }
    // Only a plan made against the running layout applies; any other layout's retyped variables move.
    const auto previous = changes.is_object() ? changes.find("previous") : changes.end();
    if (!changes.is_object() || previous == changes.end() || *previous != running.self.hash) return out;
    std::map<std::string, const nlohmann::json *> planned;
    if (const auto it = changes.find("converted"); it != changes.end() && it->is_array())
        for (const auto &c : *it)
            if (c.is_object() && c.contains("path") && c["path"].is_string())
                planned[c["path"].get<std::string>()] = &c;
    if (const auto it = changes.find("moved"); it != changes.end() && it->is_array())
        for (const auto &m : *it)
            if (m.is_object() && m.contains("path") && m["path"].is_string() && m.contains("reason") &&
                m["reason"].is_string())
                out.not_converted[m["path"].get<std::string>()] = {
                    m["reason"].get<std::string>(),
                    m.contains("from_type") && m["from_type"].is_string() ? m["from_type"].get<std::string>() : "",
                    m.contains("to_type") && m["to_type"].is_string() ? m["to_type"].get<std::string>() : ""};
    for (const layouts::Moved &m : moved) {
        const auto found = planned.find(m.path);
        if (found == planned.end()) continue;
        const layouts::Variable *was = running.self.find(m.path), *now = next.model.self.find(m.path);
        if (!was || !now) continue;
        const nlohmann::json &c = *found->second;
        Conversion conv;
        conv.path = m.path;
        conv.to_lock = now->lock;
        try {
            conv.from_type = c.at("from_type").get<std::string>();
            conv.to_type = c.at("to_type").get<std::string>();
            for (const auto &d : c.at("dropped")) conv.dropped.push_back(d.get<std::string>());
            for (const auto &x : c.at("copies")) {
                ScalarCopy copy;
                copy.from = x.at("from").get<uint64_t>();
                copy.to = x.at("to").get<uint64_t>();
                copy.count = x.at("count").get<uint64_t>();
                copy.from_stride = x.at("from_stride").get<uint64_t>();
                copy.to_stride = x.at("to_stride").get<uint64_t>();
                if (!parseCode(x.at("from_type").get<std::string>(), copy.from_type) ||
                    !parseCode(x.at("to_type").get<std::string>(), copy.to_type))
                    return bad(m.path, "names a scalar type other than s1..s8, u1..u8, f4, f8 or b1");
                if (!inside(copy.from, copy.count, copy.from_stride, copy.from_type.size, *was) ||
                    !inside(copy.to, copy.count, copy.to_stride, copy.to_type.size, *now))
                    return bad(m.path, "copies bytes outside the variable (or overlapping scalars)");
                conv.copies.push_back(copy);
            }
        } catch (const nlohmann::json::exception &e) {
            return bad(m.path, std::string("is malformed (") + e.what() + ")");
        }
        out.not_converted.erase(m.path);
        out.converted.push_back(std::move(conv));
    }
    return out;
}

void convert(const Conversion &c, char *data) noexcept {
    for (const ScalarCopy &copy : c.copies)
        for (uint64_t i = 0; i < copy.count; ++i)
            convertOne(data + copy.from + i * copy.from_stride, copy.from_type, data + copy.to + i * copy.to_stride,
                       copy.to_type);
}

void hold(const std::vector<Conversion> &all) noexcept {
    for (const Conversion &c : all) {
        shared::lockVariable(c.to_lock);
        auto seq = shared::detail::sequence(c.to_lock);
        seq.store(seq.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
        std::atomic_thread_fence(std::memory_order_release);
    }
}

void converted(const std::vector<Conversion> &all, char *data) noexcept {
    for (const Conversion &c : all) {
        convert(c, data);
        auto seq = shared::detail::sequence(c.to_lock);
        seq.store(seq.load(std::memory_order_relaxed) + 1, std::memory_order_release);
    }
}

void release(const std::vector<Conversion> &all, bool swapped) noexcept {
    for (const Conversion &c : all) {
        if (!swapped) {
            auto seq = shared::detail::sequence(c.to_lock);
            seq.store(seq.load(std::memory_order_relaxed) + 1, std::memory_order_release);
        }
        shared::unlockVariable(c.to_lock);
    }
}

}  // namespace irp::variables
