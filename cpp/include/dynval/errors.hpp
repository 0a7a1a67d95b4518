// Input errors of the dynval core: one exception type per language-neutral error kind.
//
// The kind names and every message text are fixed by docs/contract.md §2 and are identical to
// the Python facade (python/dynval/_validation.py), so a C++ caller, a Python caller and a port
// see the same words. Values inside messages are written as Python would write them (repr), which
// is what the py_repr helpers below reproduce.
#pragma once

#include <Eigen/Core>

#include <charconv>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <utility>
#include <vector>

namespace dynval {

using Index = Eigen::Index;

/// Language-neutral error kinds, in the contract's check order.
enum class error_kind {
    InvalidType,
    InvalidShape,
    ShapeMismatch,
    TooFewSamples,
    NonFiniteInput,
    InvalidParameter,
};

/// The contract's name of an error kind (used verbatim by Python, the corpus and the protocol).
inline const char* kind_name(error_kind kind) noexcept {
    switch (kind) {
        case error_kind::InvalidType: return "InvalidType";
        case error_kind::InvalidShape: return "InvalidShape";
        case error_kind::ShapeMismatch: return "ShapeMismatch";
        case error_kind::TooFewSamples: return "TooFewSamples";
        case error_kind::NonFiniteInput: return "NonFiniteInput";
        case error_kind::InvalidParameter: return "InvalidParameter";
    }
    return "InputError";
}

/// Base of every input error; `kind()` tells which contract kind it is.
class input_error : public std::invalid_argument {
public:
    input_error(error_kind kind, const std::string& message) : std::invalid_argument(message), kind_(kind) {}
    error_kind kind() const noexcept { return kind_; }

private:
    error_kind kind_;
};

#define DYNVAL_DEFINE_INPUT_ERROR(cls, kind_value)                                             \
    class cls : public input_error {                                                           \
    public:                                                                                    \
        explicit cls(const std::string& message) : input_error(error_kind::kind_value, message) {} \
    };
DYNVAL_DEFINE_INPUT_ERROR(invalid_type, InvalidType)
DYNVAL_DEFINE_INPUT_ERROR(invalid_shape, InvalidShape)
DYNVAL_DEFINE_INPUT_ERROR(shape_mismatch, ShapeMismatch)
DYNVAL_DEFINE_INPUT_ERROR(too_few_samples, TooFewSamples)
DYNVAL_DEFINE_INPUT_ERROR(non_finite_input, NonFiniteInput)
DYNVAL_DEFINE_INPUT_ERROR(invalid_parameter, InvalidParameter)
#undef DYNVAL_DEFINE_INPUT_ERROR

// ------------------------------------------------------------------------------------------
// Python-compatible text for values inside messages.

/// Python's repr of a float: shortest round-trip digits, fixed notation for exponents in
/// [-4, 16), scientific otherwise ("1e-05", "1e+16", "0.1", "3.0", "nan", "inf").
inline std::string py_repr(double value) {
    if (std::isnan(value)) return "nan";
    if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
    char buf[64];
    auto res = std::to_chars(buf, buf + sizeof(buf), value, std::chars_format::scientific);
    std::string sci(buf, res.ptr);
    bool negative = false;
    if (!sci.empty() && sci[0] == '-') {
        negative = true;
        sci.erase(0, 1);
    }
    const auto e_pos = sci.find('e');
    std::string mantissa = sci.substr(0, e_pos);
    const int exponent = std::stoi(sci.substr(e_pos + 1));
    std::string digits;
    for (char c : mantissa)
        if (c != '.') digits.push_back(c);
    std::string out = negative ? "-" : "";
    if (exponent >= -4 && exponent < 16) {
        if (exponent < 0) {
            out += "0." + std::string(static_cast<std::size_t>(-exponent - 1), '0') + digits;
        } else {
            const auto int_len = static_cast<std::size_t>(exponent) + 1;
            if (digits.size() <= int_len) {
                out += digits + std::string(int_len - digits.size(), '0') + ".0";
            } else {
                out += digits.substr(0, int_len) + "." + digits.substr(int_len);
            }
        }
    } else {
        out += digits.substr(0, 1);
        if (digits.size() > 1) out += "." + digits.substr(1);
        const int a = exponent < 0 ? -exponent : exponent;
        out += exponent < 0 ? "e-" : "e+";
        if (a < 10) out += "0";
        out += std::to_string(a);
    }
    return out;
}

inline std::string py_repr(long long value) { return std::to_string(value); }
inline std::string py_repr(long value) { return std::to_string(value); }
inline std::string py_repr(int value) { return std::to_string(value); }
inline std::string py_repr(bool value) { return value ? "True" : "False"; }

/// Python's repr of a str: single quotes unless the text holds ' and no ".
inline std::string py_repr_str(std::string_view text) {
    const bool has_single = text.find('\'') != std::string_view::npos;
    const bool has_double = text.find('"') != std::string_view::npos;
    const char quote = (has_single && !has_double) ? '"' : '\'';
    std::string out(1, quote);
    static const char* hex = "0123456789abcdef";
    for (char ch : text) {
        const auto c = static_cast<unsigned char>(ch);
        if (ch == quote || ch == '\\') {
            out.push_back('\\');
            out.push_back(ch);
        } else if (ch == '\n') {
            out += "\\n";
        } else if (ch == '\r') {
            out += "\\r";
        } else if (ch == '\t') {
            out += "\\t";
        } else if (c < 0x20 || c == 0x7f) {
            out += "\\x";
            out.push_back(hex[c >> 4]);
            out.push_back(hex[c & 0xf]);
        } else {
            out.push_back(ch);
        }
    }
    out.push_back(quote);
    return out;
}

inline std::string py_repr(const std::vector<long long>& values) {
    std::string out = "[";
    for (std::size_t i = 0; i < values.size(); ++i) {
        if (i) out += ", ";
        out += std::to_string(values[i]);
    }
    return out + "]";
}

/// A 2-D shape written as a Python tuple: "(5, 2)".
inline std::string shape_text(Index rows, Index cols) {
    return "(" + std::to_string(rows) + ", " + std::to_string(cols) + ")";
}

/// "nan", "inf" or "-inf".
inline std::string nonfinite_text(double value) {
    if (std::isnan(value)) return "nan";
    return value > 0 ? "inf" : "-inf";
}

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

namespace detail {

[[noreturn]] inline void throw_parameter(const std::string& name, const std::string& requirement,
                                         const std::string& repr) {
    throw invalid_parameter(name + " must be " + requirement + ", got " + repr);
}

/// An integer parameter with lo <= value < hi (hi < 0: no upper bound).
inline long long require_int(const param<long long>& p, const std::string& name, long long lo, long long hi,
                             const std::string& requirement) {
    if (!p.valid() || p.value() < lo || (hi >= 0 && p.value() >= hi)) throw_parameter(name, requirement, p.repr());
    return p.value();
}

inline bool require_bool(const param<bool>& p, const std::string& name) {
    if (!p.valid()) throw_parameter(name, "True or False", p.repr());
    return p.value();
}

template <class E>
E require_option(const param<E>& p, const std::string& name) {
    if (!p.valid()) throw_parameter(name, "one of " + option_traits<E>::quoted_names(), p.repr());
    return p.value();
}

inline void check_columns(Index rows, Index cols, const std::string& name) {
    if (cols == 0) throw invalid_shape(name + " must have at least one column, got shape " + shape_text(rows, cols));
}

inline void check_same_shape(Index ra, Index ca, Index rb, Index cb, const std::string& a, const std::string& b) {
    if (ra != rb || ca != cb)
        throw shape_mismatch(a + " and " + b + " must have the same shape, got " + shape_text(ra, ca) + " and " +
                             shape_text(rb, cb));
}

inline void check_min_samples(Index n, Index minimum, const std::string& function) {
    if (n < minimum)
        throw too_few_samples(function + " needs at least " + std::to_string(minimum) + " samples, got N=" +
                              std::to_string(n));
}

/// Largest accepted |value| in the data (contract §1.2): beyond it float64 sums of squares can
/// overflow, and an overflowed sum is inf in one implementation and nan in another.
constexpr double max_magnitude = 1e144;

/// Finite and |v| <= max_magnitude (false for NaN and ±inf).
inline bool in_range(double v) noexcept { return std::fabs(v) <= max_magnitude; }

/// NonFiniteInput for a bad value at `where`: non-finite, or finite but out of range.
[[noreturn]] inline void throw_bad_value(const std::string& name, double value, const std::string& where) {
    if (std::isfinite(value))
        throw non_finite_input(name + " has a value out of range (" + py_repr(value) + ") " + where +
                               ": |x| must be at most 1e+144");
    throw non_finite_input(name + " has a non-finite value (" + nonfinite_text(value) + ") " + where);
}

[[noreturn]] inline void throw_nonfinite(const std::string& name, Index row, Index col, double value) {
    throw_bad_value(name, value, "at row " + std::to_string(row) + ", column " + std::to_string(col));
}

/// Regressor viewed as (N, m*p): column q is joint q / p, column q % p.
[[noreturn]] inline void throw_nonfinite_regressor(Index sample, Index q, Index n_columns, double value) {
    throw_bad_value("regressor", value,
                    "at sample " + std::to_string(sample) + ", joint " + std::to_string(q / n_columns) +
                        ", column " + std::to_string(q % n_columns));
}

}  // namespace detail
}  // namespace dynval
