// Input errors of the dynval core: one exception type per language-neutral error kind.
//
// The kind names and every message text are fixed by docs/contract.md §2 and are identical to
// the Python facade (python/dynval/checks/_validation.py), so a C++ caller, a Python caller and a port
// see the same words. The values inside them are written the C++ way (value_text); the Python
// bindings replace a parameter's value with the caller's own argument (contract §2.1).
#pragma once

#include "types.hpp"

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
#undef DYNVAL_DEFINE_INPUT_ERROR

/// InvalidParameter. Built from its parts, `{parameter} must be {requirement}, got {value}`, it
/// keeps them, so that a binding can show the value as its own language writes the argument.
class invalid_parameter : public input_error {
public:
    explicit invalid_parameter(const std::string& message) : input_error(error_kind::InvalidParameter, message) {}
    invalid_parameter(std::string parameter, std::string requirement, const std::string& value)
        : input_error(error_kind::InvalidParameter, parameter + " must be " + requirement + ", got " + value),
          parameter_(std::move(parameter)),
          requirement_(std::move(requirement)) {}
    /// The parameter's name; empty for a message that is not of the `must be` form.
    const std::string& parameter() const noexcept { return parameter_; }
    const std::string& requirement() const noexcept { return requirement_; }

private:
    std::string parameter_, requirement_;
};

// ------------------------------------------------------------------------------------------
// Values inside messages.

/// A 2-D shape written as a tuple: "(5, 2)".
inline std::string shape_text(Index rows, Index cols) {
    return "(" + std::to_string(rows) + ", " + std::to_string(cols) + ")";
}

/// "nan", "inf" or "-inf".
inline std::string nonfinite_text(double value) {
    if (std::isnan(value)) return "nan";
    return value > 0 ? "inf" : "-inf";
}

inline std::string value_text(long long value) { return std::to_string(value); }

/// The shortest text that reads back as the same double ("0.5", "2", "1e+145", "nan"). For the
/// data's out-of-range values (|x| > 1e144) it is also the text Python's repr gives.
inline std::string value_text(double value) {
    if (!std::isfinite(value)) return nonfinite_text(value);
    char buf[64];
    const auto res = std::to_chars(buf, buf + sizeof(buf), value);
    return std::string(buf, res.ptr);
}

inline std::string value_text(const std::vector<long long>& values) {
    std::string out = "[";
    for (std::size_t i = 0; i < values.size(); ++i) {
        if (i) out += ", ";
        out += std::to_string(values[i]);
    }
    return out + "]";
}

/// An option name in a message: 'raw_values'.
inline std::string quoted(std::string_view name) { return "'" + std::string(name) + "'"; }

namespace detail {

[[noreturn]] inline void throw_parameter(const std::string& name, const std::string& requirement,
                                         const std::string& value) {
    throw invalid_parameter(name, requirement, value);
}

/// An integer parameter with lo <= value < hi (hi < 0: no upper bound).
inline long long require_int(long long value, const std::string& name, long long lo, long long hi,
                             const std::string& requirement) {
    if (value < lo || (hi >= 0 && value >= hi)) throw_parameter(name, requirement, value_text(value));
    return value;
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
        throw non_finite_input(name + " has a value out of range (" + value_text(value) + ") " + where +
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
