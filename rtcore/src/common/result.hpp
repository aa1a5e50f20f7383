// result.hpp -- irp::Result<T>: how rtcore reports load-time failures, as values.
//
// Every function that can refuse user input (module.xml, a module .so, a schedule) returns a
// Result carrying either the value or an Error whose message a user can act on: where (file:line),
// which field, what was expected.  Nothing on the RT path returns or throws errors.
#pragma once

#include "protocol/limits.hpp"

#include <string>
#include <utility>
#include <variant>

namespace irp {

struct Error {
    std::string message;
    // The control protocol's error code (protocol/control.json): refused, or not_found when the
    // request names a module or record that does not exist, or restart_required.
    std::string code = protocol::kRefused;
};

template <class T>
class [[nodiscard]] Result {
public:
    Result(T value) : v_(std::move(value)) {}
    Result(Error error) : v_(std::move(error)) {}

    bool ok() const { return v_.index() == 0; }
    explicit operator bool() const { return ok(); }

    T &value() & { return std::get<0>(v_); }
    T &&value() && { return std::get<0>(std::move(v_)); }
    const T &value() const & { return std::get<0>(v_); }
    T *operator->() { return &value(); }
    const T *operator->() const { return &value(); }
    T &operator*() & { return value(); }
    const T &operator*() const & { return value(); }

    const Error &error() const { return std::get<1>(v_); }

private:
    std::variant<T, Error> v_;
};

// Result<void>: success or an Error.
struct Ok {};
using Status = Result<Ok>;

}  // namespace irp
