// result.hpp -- irp::Result<T>: how irpd and the SDK's libraries (indurop::kinematics) report
// load-time failures, as values.
//
// Every function that can refuse user input (module.xml, a module .so, a schedule, a URDF) returns
// a Result carrying either the value or an Error whose message a user can act on: where
// (file:line), which field, what was expected.  The place is also given as fields (Place), which
// the control protocol sends as they are, so that no reader has to find it in the text.  Nothing
// on the RT path returns or throws errors.
#pragma once

#include <string>
#include <utility>
#include <variant>

namespace irp {

// Where in a set's files an error is: the fields that apply (empty or 0: not known).
struct Place {
    Place() = default;
    explicit Place(std::string file_, int line_ = 0, int column_ = 0, std::string module_ = {}, std::string field_ = {})
        : file(std::move(file_)), line(line_), column(column_), module(std::move(module_)), field(std::move(field_)) {}

    std::string file;    // the file, as irpd names it (a set's files by absolute path)
    int line = 0;        // counted from 1
    int column = 0;      // counted from 1
    std::string module;  // the module (or executor) it is about
    std::string field;   // the module.xml element: period, executor, property.restart, ...
};

// The control protocol's code of an Error that names no other (protocol/control.json's `refused`;
// rtcore/src/protocol/errors.hpp checks at compile time that it is the spec's).
inline constexpr const char *kErrorRefused = "refused";

struct Error {
    Error() = default;
    Error(std::string message_, std::string code_ = kErrorRefused, Place place_ = {})
        : message(std::move(message_)), code(std::move(code_)), place(std::move(place_)) {}

    std::string message;  // the whole sentence, place included ("module.xml:12: module 'x': ...")
    // The control protocol's error code (protocol/control.json): refused, or not_found when the
    // request names a module or record that does not exist, or restart_required.
    std::string code = kErrorRefused;
    Place place;
};

// An error about a whole file: "<file>: what", placed at the file.
inline Error fileError(const std::string &file, const std::string &what) {
    return Error{file + ": " + what, kErrorRefused, Place{file}};
}

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
