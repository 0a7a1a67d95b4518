// The contract's finiteness check (§1.2): the first NaN, ±inf or out-of-range value of an
// array in row-major order, found by a cheap block test and an exact scan of a failing block.
#pragma once

#include "errors.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <optional>

namespace dynval {

/// First NaN, ±inf or out-of-range value (|x| > max_magnitude) of an array, in row-major order.
struct nonfinite_entry {
    Index row = 0;
    Index col = 0;
    double value = 0.0;
};

namespace detail {

/// Row-major scan of rows [begin, begin + count) for the first non-finite entry.
template <class D>
std::optional<nonfinite_entry> scan_nonfinite(const Eigen::MatrixBase<D>& a, Index begin, Index count) {
    for (Index i = begin; i < begin + count; ++i)
        for (Index j = 0; j < a.cols(); ++j) {
            const double v = a.coeff(i, j);
            if (!in_range(v)) return nonfinite_entry{i, j, v};
        }
    return std::nullopt;
}

}  // namespace detail


/// First non-finite entry of `a` in row-major order (the contract's "first bad index").
template <class D>
std::optional<nonfinite_entry> first_nonfinite(const Eigen::MatrixBase<D>& a) {
    constexpr Index block = 256;
    if (a.cols() == 0) return std::nullopt;  // maxCoeff of an empty block is undefined
    for (Index start = 0; start < a.rows(); start += block) {
        const Index nb = std::min(block, a.rows() - start);
        // A block sum is finite whenever every entry is (barring overflow, which only costs a
        // scan that then finds nothing); the largest magnitude catches values out of range.
        const auto rows = a.middleRows(start, nb);
        if (!std::isfinite(rows.sum()) || !(rows.cwiseAbs().maxCoeff() <= detail::max_magnitude)) {
            if (auto hit = detail::scan_nonfinite(a, start, nb)) return hit;
        }
    }
    return std::nullopt;
}

}  // namespace dynval
