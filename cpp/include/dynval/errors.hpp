// Input errors of the dynval core: one exception type per language-neutral error kind.
//
// The kind names and every message text are fixed by docs/contract.md §2 and are identical to
// the Python facade (python/dynval/_validation.py), so a C++ caller, a Python caller and a port
// see the same words. Values inside messages are written as Python would write them (repr.hpp);
// parameters that may arrive invalid are param<T> (param.hpp).
#pragma once

#include "param.hpp"
#include "repr.hpp"

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
DYNVAL_DEFINE_INPUT_ERROR(invalid_parameter, InvalidParameter)
#undef DYNVAL_DEFINE_INPUT_ERROR

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
