// Named options of the contract (§3, §5.1), as enums with their contract names.
#pragma once

#include "errors.hpp"

#include <array>
#include <optional>
#include <string>
#include <string_view>

namespace dynval {

/// How per-joint values are combined (scikit-learn's `multioutput`, plus the lesson's `pooled`).
enum class multioutput { pooled, raw_values, uniform_average, variance_weighted };
/// Pooled RMSE denominator: N·m (`per_element`, the lesson's formula) or N (`per_sample`, its code).
enum class rmse_convention { per_element, per_sample };
/// Noise model of the information criteria.
enum class noise_model { pooled, per_joint, full };
/// Portmanteau statistic.
enum class portmanteau_test { ljung_box, box_pierce };

template <class E>
struct option_traits;  // specialised below for each option enum

namespace detail {
template <class E, std::size_t K>
struct named_options {
    static std::optional<E> parse_in(const std::array<const char*, K>& names, std::string_view text) {
        for (std::size_t i = 0; i < K; ++i)
            if (text == names[i]) return static_cast<E>(i);
        return std::nullopt;
    }
    static std::string quoted(const std::array<const char*, K>& names) {
        std::string out;
        for (std::size_t i = 0; i < K; ++i) {
            if (i) out += ", ";
            out += dynval::quoted(names[i]);
        }
        return out;
    }
};
}  // namespace detail

#define DYNVAL_OPTION_TRAITS(E, K, ...)                                                              \
    template <>                                                                                      \
    struct option_traits<E> {                                                                        \
        static constexpr std::array<const char*, K> names{__VA_ARGS__};                              \
        static std::optional<E> parse(std::string_view t) {                                          \
            return detail::named_options<E, K>::parse_in(names, t);                                  \
        }                                                                                            \
        static bool valid(E v) { return static_cast<std::size_t>(v) < K; }                             \
        static const char* name(E v) { return valid(v) ? names[static_cast<std::size_t>(v)] : "?"; }  \
        static std::string quoted_names() { return detail::named_options<E, K>::quoted(names); }     \
    };
DYNVAL_OPTION_TRAITS(multioutput, 4, "pooled", "raw_values", "uniform_average", "variance_weighted")
DYNVAL_OPTION_TRAITS(rmse_convention, 2, "per_element", "per_sample")
DYNVAL_OPTION_TRAITS(noise_model, 3, "pooled", "per_joint", "full")
DYNVAL_OPTION_TRAITS(portmanteau_test, 2, "ljung_box", "box_pierce")
#undef DYNVAL_OPTION_TRAITS

/// The contract name of an option value ("raw_values", "full", ...).
template <class E>
const char* option_name(E value) {
    return option_traits<E>::name(value);
}

/// The option called `name` ("raw_values"), for callers that read options as text; an unknown
/// name is InvalidParameter for `parameter`.
template <class E>
E option_from_name(std::string_view name, const std::string& parameter) {
    const auto value = option_traits<E>::parse(name);
    if (!value) detail::throw_parameter(parameter, "one of " + option_traits<E>::quoted_names(), quoted(name));
    return *value;
}

namespace detail {
/// An option value that is one of the enumerators (an enum cast from any other integer is not).
template <class E>
E require_option(E value, const std::string& parameter) {
    if (!option_traits<E>::valid(value))
        throw_parameter(parameter, "one of " + option_traits<E>::quoted_names(),
                        std::to_string(static_cast<long long>(value)));
    return value;
}
}  // namespace detail

}  // namespace dynval
