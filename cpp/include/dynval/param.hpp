// param<T>: a parameter value, or the text of an argument that could not be converted to T,
// checked only after the data in the contract's order (docs/contract.md §2.1).
#pragma once

#include "repr.hpp"

#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

namespace dynval {

// ------------------------------------------------------------------------------------------
// Parameters that may arrive invalid (from Python or from text) and are checked only after the
// data, in the contract's order. A C++ caller passes plain values; they convert implicitly.

template <class T>
struct option_traits;  // specialised for the option enums in options.hpp

/// A parameter value, or the repr of an argument that could not even be converted to T.
template <class T>
class param {
public:
    param(T value) : value_(value), repr_(repr_of(value)) {}  // NOLINT: implicit on purpose

    template <class U = T, class = std::enable_if_t<std::is_same_v<U, long long>>>
    param(int value) : param(static_cast<long long>(value)) {}  // NOLINT
    template <class U = T, class = std::enable_if_t<std::is_same_v<U, long long>>>
    param(long value) : param(static_cast<long long>(value)) {}  // NOLINT

    // Option enums are also accepted by name (`"raw_values"`); unknown names stay invalid.
    template <class U = T, class = std::enable_if_t<std::is_enum_v<U>>>
    param(std::string_view name) : repr_(py_repr_str(name)) {  // NOLINT
        value_ = option_traits<T>::parse(name);
    }
    template <class U = T, class = std::enable_if_t<std::is_enum_v<U>>>
    param(const char* name) : param(std::string_view(name)) {}  // NOLINT
    template <class U = T, class = std::enable_if_t<std::is_enum_v<U>>>
    param(const std::string& name) : param(std::string_view(name)) {}  // NOLINT

    /// A value shown as `repr` in errors (e.g. the caller's own spelling of a sequence).
    param(T value, std::string repr) : value_(std::move(value)), repr_(std::move(repr)) {}

    /// An argument that is not a T at all, with the text to show in the error.
    static param invalid(std::string repr) {
        param p;
        p.repr_ = std::move(repr);
        return p;
    }

    bool valid() const noexcept { return value_.has_value(); }
    const T& value() const { return *value_; }
    const std::string& repr() const noexcept { return repr_; }

private:
    param() = default;
    static std::string repr_of(const T& v) {
        if constexpr (std::is_enum_v<T>) {
            return py_repr_str(option_traits<T>::name(v));
        } else {
            return py_repr(v);
        }
    }
    std::optional<T> value_;
    std::string repr_;
};

}  // namespace dynval
