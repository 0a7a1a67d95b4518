// Compensated (Neumaier) running sums, and means and differences formed without losing the
// digits a large shift would cost.
#pragma once

#include <cmath>

namespace dynval {
namespace detail {

/// Neumaier's compensated summation of one running value.
struct compensated {
    double sum = 0.0;
    double carry = 0.0;
    void add(double x) noexcept {
        const double t = sum + x;
        if (std::abs(sum) >= std::abs(x)) {
            carry += (sum - t) + x;
        } else {
            carry += (x - t) + sum;
        }
        sum = t;
    }
    void add(const compensated& other) noexcept {
        add(other.sum);
        add(other.carry);
    }
    // With an infinite term the carry is inf − inf = nan: the IEEE sum is the running sum itself.
    double value() const noexcept { return std::isfinite(sum) ? sum + carry : sum; }
};

/// Adds n·(a − b) to `sum` without rounding it first (exact difference and product terms).
inline void add_scaled_difference(compensated& sum, double n, double a, double b) {
    const double d = a - b;
    const double bv = d - a;
    const double d_err = (a - (d - bv)) + (-b - bv);  // a − b = d + d_err exactly
    const double p = n * d;
    sum.add(p);
    sum.add(std::fma(n, d, -p));
    sum.add(n * d_err);
}

/// (n·shift + sum)/n with one rounding in practice: n·shift is split exactly (fma), the total
/// is carried as a compensated sum, and the division is corrected by its exact remainder.
inline double shifted_mean(double shift, const compensated& sum, double n) {
    const double p = n * shift;
    const double p_err = std::fma(n, shift, -p);
    compensated total;
    total.add(p);
    total.add(p_err);
    total.add(sum);
    const double hi = total.sum, lo = total.carry;
    double q = hi / n;
    const double rem = std::fma(-q, n, hi);
    q += (rem + lo) / n;
    return std::isfinite(q) ? q : shift + sum.value() / n;
}

}  // namespace detail
}  // namespace dynval
