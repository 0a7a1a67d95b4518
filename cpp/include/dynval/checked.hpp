// Checked 64-bit arithmetic for sizes and counts that come from the caller.
//
// The core is public: a C++ caller can pass any long long as a column count, a segment length or
// a lag. A product or sum of such values that wraps around silently turns a bad argument into a
// plausible size (2^62 + 1 columns times 4 joints "equals" 4) and the loops that trust it read
// out of bounds. Every size product and sum built from caller values goes through these helpers.
#pragma once

#include <limits>
#include <optional>

namespace dynval::detail {

/// a·b, or nothing when the exact product does not fit in a long long.
constexpr std::optional<long long> checked_mul(long long a, long long b) noexcept {
    constexpr long long hi = std::numeric_limits<long long>::max();
    constexpr long long lo = std::numeric_limits<long long>::min();
    if (a == 0 || b == 0) return 0LL;
    if (a > 0 ? (b > 0 ? a > hi / b : b < lo / a) : (b > 0 ? a < lo / b : a < hi / b)) return std::nullopt;
    return a * b;
}

/// a + b, or nothing when the exact sum does not fit in a long long.
constexpr std::optional<long long> checked_add(long long a, long long b) noexcept {
    constexpr long long hi = std::numeric_limits<long long>::max();
    constexpr long long lo = std::numeric_limits<long long>::min();
    if ((b > 0 && a > hi - b) || (b < 0 && a < lo - b)) return std::nullopt;
    return a + b;
}

}  // namespace dynval::detail
