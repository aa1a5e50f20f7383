// property.h -- irp::Property, the read-only view of a module's <property> values from module.xml.
//
// Header-only and ABI-neutral: it wraps the C list of module_abi.h, so the same object can be
// handed to a module built with another compiler version.  Typed getters throw
// irp::PropertyError (derived from std::runtime_error) when a value does not parse; thrown from
// initialize(), that refuses the module with the message.
#pragma once

#include <indurop/module_abi.h>

#include <charconv>
#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>

namespace irp {

class PropertyError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

class Property {
public:
    Property() = default;
    explicit Property(const indurop_property_list *list) : list_(list) {}

    std::size_t size() const { return list_ ? list_->count : 0; }
    std::string_view nameAt(std::size_t i) const { return list_->entries[i].name; }
    std::string_view valueAt(std::size_t i) const { return list_->entries[i].value; }

    bool has(std::string_view name) const { return find(name).has_value(); }

    // The value as written, or nullopt when module.xml does not set it.
    std::optional<std::string_view> find(std::string_view name) const {
        for (std::size_t i = 0; i < size(); ++i)
            if (nameAt(i) == name) return valueAt(i);
        return std::nullopt;
    }

    std::string get(std::string_view name, std::string_view fallback = {}) const {
        return std::string(find(name).value_or(fallback));
    }

    // A file named by a property (ioconfig.xml, a URDF...): as written when absolute, else relative
    // to the folder of the set's module.xml (irpd passes it as the property indurop.set_dir).
    std::string path(std::string_view name, std::string_view fallback = {}) const {
        std::string file = get(name, fallback);
        if (file.empty() || file.front() == '/') return file;
        auto dir = find("indurop.set_dir");
        return dir && !dir->empty() ? std::string(*dir) + "/" + file : file;
    }

    // Integers and floating point values; bool accepts true/false/1/0.
    template <class T>
    T get(std::string_view name, T fallback) const {
        auto text = find(name);
        if (!text) return fallback;
        return parse<T>(name, *text);
    }

    template <class T>
    T require(std::string_view name) const {
        auto text = find(name);
        if (!text) throw PropertyError("property '" + std::string(name) + "' is required but not set in module.xml");
        return parse<T>(name, *text);
    }

private:
    template <class T>
    static T parse(std::string_view name, std::string_view text) {
        if constexpr (std::is_same_v<T, bool>) {
            if (text == "true" || text == "1") return true;
            if (text == "false" || text == "0") return false;
            fail(name, text, "true, false, 1 or 0");
        } else if constexpr (std::is_arithmetic_v<T>) {
            T value{};
            auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
            if (ec == std::errc::result_out_of_range) fail(name, text, "a value in range");
            if (ec != std::errc() || end != text.data() + text.size())
                fail(name, text, std::is_integral_v<T> ? "an integer" : "a number");
            return value;
        } else {
            static_assert(std::is_convertible_v<std::string_view, T>, "Property::get: unsupported type");
            return T(text);
        }
    }

    [[noreturn]] static void fail(std::string_view name, std::string_view text, const char *expected) {
        throw PropertyError("property '" + std::string(name) + "': expected " + expected + ", got '" +
                            std::string(text) + "'");
    }

    const indurop_property_list *list_ = nullptr;
};

}  // namespace irp
