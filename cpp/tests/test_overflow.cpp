// Sizes and counts that do not fit in 64 bits: the public C++ API rejects them with the contract's
// InvalidParameter instead of wrapping and reading out of bounds.
#include <dynval/dynval.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

namespace {

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
constexpr long long big = std::numeric_limits<long long>::max();

Eigen::MatrixXd ramp(Eigen::Index rows, Eigen::Index cols) {
    Eigen::MatrixXd a(rows, cols);
    for (Eigen::Index i = 0; i < rows; ++i)
        for (Eigen::Index j = 0; j < cols; ++j) a(i, j) = std::sin(0.3 * static_cast<double>(i * cols + j));
    return a;
}

TEST(CheckedArithmetic, ProductsAndSums) {
    using dynval::detail::checked_add;
    using dynval::detail::checked_mul;
    EXPECT_EQ(checked_mul(6, 7), 42);
    EXPECT_EQ(checked_mul(0, big), 0);
    EXPECT_EQ(checked_mul(big, 1), big);
    EXPECT_FALSE(checked_mul((1LL << 62) + 1, 4).has_value());
    EXPECT_FALSE(checked_mul(big, 2).has_value());
    EXPECT_FALSE(checked_mul(-big, 2).has_value());
    EXPECT_EQ(checked_mul(-3, 5), -15);
    EXPECT_EQ(checked_add(big - 1, 1), big);
    EXPECT_FALSE(checked_add(big, 1).has_value());
    EXPECT_FALSE(checked_add(-big, -2).has_value());
}

// 2^62 + 1 columns on 4 joints: the product wraps to 4 = the regressor's column count.
TEST(Overflow, CrossCorrelationColumnCountProduct) {
    const Eigen::MatrixXd e = ramp(12, 4), y = ramp(12, 4);
    try {
        dynval::cross_correlation(e, y, (1LL << 62) + 1, 0);
        FAIL() << "accepted n_columns = 2^62 + 1";
    } catch (const dynval::input_error& err) {
        EXPECT_EQ(err.kind(), dynval::error_kind::InvalidParameter);
        EXPECT_EQ(std::string(err.what()),
                  "n_columns must be a positive integer with m*n_columns = 4, got 4611686018427387905");
    }
}

// Lengths (2^63 − 1) + (2^63 − 1) + 12 wrap to 10 = N.
TEST(Overflow, SegmentLengthsThatWrapToN) {
    const std::vector<long long> lengths{big, big, 12};
    const Eigen::MatrixXd col_major = ramp(10, 2);
    const RowMatrix row_major = col_major;
    for (int layout = 0; layout < 2; ++layout) {
        try {
            if (layout == 0) dynval::autocorrelation(col_major, 1, true, lengths);
            else dynval::autocorrelation(row_major, 1, true, lengths);
            FAIL() << "accepted lengths whose sum wraps to N";
        } catch (const dynval::input_error& err) {
            EXPECT_EQ(err.kind(), dynval::error_kind::InvalidParameter) << err.what();
        }
    }
    EXPECT_THROW(dynval::ljung_box(col_major, std::vector<long long>{1}, 0, lengths), dynval::invalid_parameter);
    EXPECT_THROW(dynval::cross_correlation(col_major, col_major, 1, 0, true, lengths), dynval::invalid_parameter);
    EXPECT_THROW(dynval::segment_starts(lengths, 10), dynval::invalid_parameter);
    // A length sum that wraps to a negative value is rejected too, not read as a short record.
    EXPECT_THROW(dynval::segment_starts(std::vector<long long>{big, 2}, 10), dynval::invalid_parameter);
}

// The streaming accumulator's buffers are (max_lag + 1)·m cells: a product that does not fit is
// refused before anything is allocated.
TEST(Overflow, LagAccumulatorBufferSize) {
    EXPECT_THROW(dynval::lag_accumulator(4, (1LL << 62)), std::length_error);
    EXPECT_THROW(dynval::lag_accumulator(1, big), std::length_error);
}

// The same for every buffer of the streaming state: m·p, (xcorr_lags + 1)·m·p and m·m (the Gram)
// that wrap are refused, not allocated short.
TEST(Overflow, StreamStateBufferSizes) {
    using dynval::stream_layout;
    EXPECT_THROW(dynval::stream_state(stream_layout{4, (1LL << 62) + 1, 1, 1, false}), std::length_error);
    EXPECT_THROW(dynval::stream_state(stream_layout{2, 1LL << 61, 3, 3, false}), std::length_error);
    EXPECT_THROW(dynval::stream_state(stream_layout{(1LL << 32) + 1, 0, 0, 0, true}), std::length_error);
    EXPECT_THROW(dynval::stream_state(stream_layout{1, 0, big, 0, false}), std::length_error);
    EXPECT_NO_THROW(dynval::stream_state(stream_layout{3, 4, 5, 2, true}));
}

// The documented bound on a state (contract §4.1): 8(L+1)m + (L+1) + 5(Lx+1)mp + 2m² + 12m + 6mp
// numbers at most stream_state::max_cells (2^27); a layout over it is refused before allocating.
TEST(Overflow, StreamStateBound) {
    using dynval::stream_layout;
    constexpr long long limit = dynval::stream_state::max_cells;
    static_assert(limit == 1LL << 27);
    // m = 1, p = 0: 9(L+1) + 12 numbers; the largest L that fits, and one more
    const long long fits = (limit - 12) / 9 - 1;
    EXPECT_NO_THROW(dynval::stream_state::check_fits(stream_layout{1, 0, fits, 0, false}));  // not allocated: 1 GiB
    EXPECT_THROW(dynval::stream_state(stream_layout{1, 0, fits + 1, 0, false}), std::length_error);
    EXPECT_THROW(dynval::stream_state(stream_layout{6, 0, 30000000, 0, false}), std::length_error);
    EXPECT_THROW(dynval::stream_state(stream_layout{524287, 0, 143, 50, false}), std::length_error);
    EXPECT_THROW(dynval::stream_state(stream_layout{2, 3000, 25000, 25000, true}), std::length_error);
    EXPECT_THROW(dynval::lag_accumulator(6, 30000000), std::length_error);
}

// Found by tests/test_fuzz.py: first_nonfinite of an (N, 0) array took the maxCoeff of an empty
// block (undefined; a segfault through _core.first_nonfinite).
TEST(EmptyInput, FirstNonfiniteOfNoColumns) {
    const Eigen::MatrixXd none(5, 0);
    EXPECT_FALSE(dynval::first_nonfinite(none).has_value());
    const Eigen::MatrixXd empty(0, 0);
    EXPECT_FALSE(dynval::first_nonfinite(empty).has_value());
}

// The flat test of contiguous rows must find the same first bad entry as a plain row-major scan,
// wherever it is (first and last element, block edges, tail beyond the eight lanes) and whatever
// it is (NaN, ±inf, finite but beyond max_magnitude); strided input takes the block route.
TEST(Finiteness, FirstNonfiniteMatchesARowMajorScan) {
    using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    const double bad[] = {std::nan(""), std::numeric_limits<double>::infinity(),
                          -std::numeric_limits<double>::infinity(), 2e144, -1.5e200};
    for (Eigen::Index cols : {1, 3, 7, 9}) {
        const Eigen::Index rows = 5000 / cols + 3;
        RowMatrix a = RowMatrix::Random(rows, cols) * 1e144;  // in range: |x| <= 1e144
        EXPECT_FALSE(dynval::first_nonfinite(a).has_value());
        const Eigen::Index n = rows * cols;
        for (Eigen::Index flat : {Eigen::Index{0}, Eigen::Index{7}, Eigen::Index{4095}, Eigen::Index{4096}, n - 9, n - 1}) {
            for (double v : bad) {
                RowMatrix b = a;
                b(flat / cols, flat % cols) = v;
                if (flat + 3 < n) b((flat + 3) / cols, (flat + 3) % cols) = std::nan("");  // a later one
                for (const auto& hit : {dynval::first_nonfinite(b), dynval::first_nonfinite(Eigen::MatrixXd(b))}) {
                    ASSERT_TRUE(hit.has_value()) << cols << " " << flat << " " << v;
                    EXPECT_EQ(hit->row, flat / cols);
                    EXPECT_EQ(hit->col, flat % cols);
                    EXPECT_TRUE(std::isnan(v) ? std::isnan(hit->value) : hit->value == v);
                }
            }
        }
    }
}

// Neumaier's carry is inf − inf = nan once an infinite term is added: the sum is the IEEE one.
TEST(Compensated, InfiniteTermsGiveTheIeeeSum) {
    dynval::detail::compensated s;
    s.add(1.0);
    s.add(-std::numeric_limits<double>::infinity());
    EXPECT_EQ(s.value(), -std::numeric_limits<double>::infinity());
}

// Data whose squares underflow (contract §1.3): the same R² and a scaled-back RMSE.
TEST(Scale, TinyDataKeepTheirDigits) {
    const Eigen::MatrixXd t = ramp(40, 2), p = 0.9 * ramp(40, 2).array() + 0.01;
    for (double s : {1e-162, 1e-310, 1e80, 1e-80}) {
        const Eigen::MatrixXd ts = t * s, ps = p * s;
        const double tol = s < 1e-300 ? 1e-9 : 1e-13;  // subnormal data hold fewer digits themselves
        EXPECT_NEAR(dynval::r2(ts, ps).value, dynval::r2(t, p).value, tol) << s;
        EXPECT_NEAR(dynval::rmse(ts, ps).value / s, dynval::rmse(t, p).value, tol * dynval::rmse(t, p).value) << s;
        const auto q = dynval::box_pierce(Eigen::MatrixXd(ts - ps), std::vector<long long>{5});
        const auto q1 = dynval::box_pierce(Eigen::MatrixXd(t - p), std::vector<long long>{5});
        EXPECT_NEAR(q.statistic(0, 0), q1.statistic(0, 0), 1e3 * tol * q1.statistic(0, 0)) << s;
        const auto x = dynval::cross_correlation(Eigen::MatrixXd(ts - ps), ts, 1, 2);
        const auto x1 = dynval::cross_correlation(Eigen::MatrixXd(t - p), t, 1, 2);
        EXPECT_NEAR((x.rho - x1.rho).cwiseAbs().maxCoeff(), 0.0, 10 * tol) << s;
    }
}

}  // namespace
