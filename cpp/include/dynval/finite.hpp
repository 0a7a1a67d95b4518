// The contract's finiteness check (§1.2): the first NaN, ±inf or out-of-range value of an
// array in row-major order, found by a cheap block test and an exact scan of a failing block.
#pragma once

#include "errors.hpp"
#include "simd.hpp"

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

/// Whether every one of `count` contiguous values is finite and in range: x·0 is 0 for a finite x
/// and NaN otherwise (NaN sticks in a sum), and the largest magnitude catches values out of range.
/// Eight independent lanes (vector types, an AVX2 clone where available).
DYNVAL_VECTOR_CLONES inline bool all_in_range(const double* DYNVAL_RESTRICT x, Index count) {
    Index done = 0;
    bool ok = true;
#if defined(DYNVAL_VECTOR_TYPES)
    vec4 nan_lane[2] = {}, big[2] = {};
    for (; done + 8 <= count; done += 8)
        for (int h = 0; h < 2; ++h) {
            vec4 v;
            load4(v, x + done + 4 * h);
            const vec4 a = v < 0.0 ? -v : v;
            nan_lane[h] += v * 0.0;
            big[h] = a > big[h] ? a : big[h];
        }
    for (int h = 0; h < 2; ++h)
        for (int l = 0; l < 4; ++l) ok = ok && nan_lane[h][l] == 0.0 && big[h][l] <= max_magnitude;
#endif
    for (Index i = done; i < count; ++i) ok = ok && in_range(x[i]);
    return ok;
}

}  // namespace detail

/// First non-finite entry of `a` in row-major order (the contract's "first bad index").
template <class D>
std::optional<nonfinite_entry> first_nonfinite(const Eigen::MatrixBase<D>& a) {
    constexpr Index block = 256;
    if (a.cols() == 0) return std::nullopt;  // maxCoeff of an empty block is undefined
    if constexpr ((static_cast<int>(D::Flags) & Eigen::RowMajorBit) && (static_cast<int>(D::Flags) & Eigen::DirectAccessBit)) {
        // Contiguous rows (a numpy array with its canonical strides): one flat pass, and an exact
        // scan only of a block that fails it.
        if (a.derived().innerStride() == 1 && a.derived().outerStride() == a.cols()) {
            const Index rows_per_block = std::max<Index>(1, 4096 / a.cols());
            for (Index start = 0; start < a.rows(); start += rows_per_block) {
                const Index nb = std::min(rows_per_block, a.rows() - start);
                if (!detail::all_in_range(a.derived().data() + start * a.cols(), nb * a.cols()))
                    if (auto hit = detail::scan_nonfinite(a, start, nb)) return hit;
            }
            return std::nullopt;
        }
    }
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
