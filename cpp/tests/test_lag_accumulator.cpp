// Tests of the streaming lag accumulator (lag_accumulator.hpp). Expected values come from a
// direct long-double loop over the products written here (two-pass overall mean, segments by
// explicit membership), and from dynval::autocorrelation / ljung_box on the concatenated data,
// which computes the lag sums by a different route (overall mean first, then products).
#include <dynval/dynval.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <ostream>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// AR(1)-coloured noise (so the lags carry signal) around `offset`, plus a slow drift.
MatrixXd coloured(Index rows, Index cols, unsigned seed, double offset = 0.0) {
    std::mt19937_64 gen(seed);
    std::normal_distribution<double> normal;
    MatrixXd a(rows, cols);
    for (Index j = 0; j < cols; ++j) {
        double prev = 0.0;
        for (Index i = 0; i < rows; ++i) {
            prev = 0.7 * prev + normal(gen);
            a(i, j) = offset + prev + 0.3 * std::sin(0.01 * static_cast<double>(i) + static_cast<double>(j));
        }
    }
    return a;
}

/// Direct loop: ρ̂(ℓ) with the overall mean, products only within segments (starts, first 0).
MatrixXd direct_acf(const MatrixXd& e, const std::vector<Index>& starts, Index max_lag, bool adjusted) {
    const Index n = e.rows();
    std::vector<Index> seg(static_cast<std::size_t>(n));
    for (Index k = 0, s = 0; k < n; ++k) {
        while (s + 1 < static_cast<Index>(starts.size()) && k >= starts[static_cast<std::size_t>(s + 1)]) ++s;
        seg[static_cast<std::size_t>(k)] = s;
    }
    MatrixXd rho(max_lag + 1, e.cols());
    for (Index j = 0; j < e.cols(); ++j) {
        // Values relative to the first one (exact in long double), so the mean of an offset
        // signal is not limited by the ulp of the offset (1e7 has an 80-bit ulp of ~1e-12).
        std::vector<long double> v(static_cast<std::size_t>(n));
        for (Index k = 0; k < n; ++k) v[static_cast<std::size_t>(k)] = static_cast<long double>(e(k, j)) - e(0, j);
        const auto x = [&](Index k) { return v[static_cast<std::size_t>(k)]; };
        long double mean = 0;
        for (Index k = 0; k < n; ++k) mean += x(k);
        mean /= n;
        long double r0 = 0;
        for (Index k = 0; k < n; ++k) r0 += (x(k) - mean) * (x(k) - mean);
        r0 /= n;
        for (Index l = 0; l <= max_lag; ++l) {
            long double s = 0;
            Index count = 0;
            for (Index k = l; k < n; ++k) {
                if (seg[static_cast<std::size_t>(k)] != seg[static_cast<std::size_t>(k - l)]) continue;
                s += (x(k) - mean) * (x(k - l) - mean);
                ++count;
            }
            const long double d = adjusted && l > 0 ? static_cast<long double>(count) : static_cast<long double>(n);
            rho(l, j) = static_cast<double>((s / d) / r0);
        }
    }
    return rho;
}

std::vector<long long> as_ll(const std::vector<Index>& v) { return {v.begin(), v.end()}; }

double max_abs_diff(const dynval::row_matrix& a, const MatrixXd& b) {
    return (a - b).cwiseAbs().maxCoeff();
}

/// Feeds rows [lo, hi) of `e` in random blocks of 1..max_block rows, breaking the segment
/// before every start in (lo, hi) — and, for a start at lo, before any row.
template <class E>
void feed(dynval::lag_accumulator& acc, const E& e, Index lo, Index hi, const std::set<Index>& starts,
          std::mt19937_64& gen, Index max_block) {
    std::uniform_int_distribution<Index> size(1, max_block);
    Index r = lo;
    while (r < hi) {
        if (r > 0 && starts.count(r)) acc.break_segment();
        auto next = starts.upper_bound(r);
        Index stop = next == starts.end() ? hi : std::min(hi, *next);
        stop = std::min(stop, r + size(gen));
        acc.update(e.middleRows(r, stop - r));
        r = stop;
    }
}

/// A random merge tree over rows [lo, hi): leaves are fed in random blocks; a segment start at
/// a junction is marked at the end of the left range or the start of the right one (random).
template <class E>
dynval::lag_accumulator tree(const E& e, Index lo, Index hi, const std::set<Index>& starts, Index max_lag,
                             std::mt19937_64& gen, Index max_block) {
    dynval::lag_accumulator acc(e.cols(), max_lag);
    if (hi - lo < 40 || std::uniform_int_distribution<int>(0, 4)(gen) == 0) {
        feed(acc, e, lo, hi, starts, gen, max_block);
        return acc;
    }
    const Index mid = std::uniform_int_distribution<Index>(lo + 1, hi - 1)(gen);
    std::set<Index> left_starts, right_starts;
    for (Index s : starts) (s < mid ? left_starts : right_starts).insert(s);
    const bool break_at_left_end = right_starts.count(mid) && std::uniform_int_distribution<int>(0, 1)(gen);
    if (break_at_left_end) right_starts.erase(mid);
    dynval::lag_accumulator left = tree(e, lo, mid, left_starts, max_lag, gen, max_block);
    if (break_at_left_end) left.break_segment();
    const dynval::lag_accumulator right = tree(e, mid, hi, right_starts, max_lag, gen, max_block);
    if (std::uniform_int_distribution<int>(0, 3)(gen) == 0) left.merge(dynval::lag_accumulator(e.cols(), max_lag));
    left.merge(right);
    return left;
}

struct Case {
    Index n, m, max_lag;
    std::vector<Index> starts;  // segment starts, first 0
    double offset;
    Index max_block;
};

void PrintTo(const Case& c, std::ostream* os) {
    *os << "n=" << c.n << " m=" << c.m << " max_lag=" << c.max_lag << " segments=" << c.starts.size()
        << " offset=" << c.offset << " max_block=" << c.max_block;
}

class LagAccumulatorCases : public ::testing::TestWithParam<Case> {};

TEST_P(LagAccumulatorCases, OneShotSplitsAndMergeTreesAgree) {
    const Case c = GetParam();
    const MatrixXd e = coloured(c.n, c.m, 1000 + static_cast<unsigned>(c.n + c.max_lag), c.offset);
    const std::set<Index> starts(c.starts.begin(), c.starts.end());
    const std::vector<long long> segs = as_ll(c.starts);

    dynval::lag_accumulator one(c.m, c.max_lag);
    for (std::size_t s = 0; s < c.starts.size(); ++s) {
        const Index a = c.starts[s], b = s + 1 < c.starts.size() ? c.starts[s + 1] : c.n;
        one.break_segment();
        one.update(e.middleRows(a, b - a));
    }
    for (bool adjusted : {true, false}) {
        const dynval::row_matrix rho_one = one.result(adjusted);
        const dynval::row_matrix rho_core = dynval::autocorrelation(e, c.max_lag, adjusted, segs);
        const MatrixXd rho_direct = direct_acf(e, c.starts, c.max_lag, adjusted);
        // ρ is R(ℓ)/R(0): absolute differences are relative to R(0).
        EXPECT_LE(max_abs_diff(rho_one, rho_direct), 1e-14) << "adjusted=" << adjusted;
        EXPECT_LE(max_abs_diff(rho_one, rho_core), 1e-14) << "adjusted=" << adjusted;
        std::mt19937_64 gen(7 + static_cast<unsigned>(adjusted));
        for (int trial = 0; trial < 12; ++trial) {
            dynval::lag_accumulator split(c.m, c.max_lag);
            feed(split, e, 0, c.n, starts, gen, c.max_block);
            EXPECT_LE(max_abs_diff(split.result(adjusted), rho_one), 1e-14) << "split " << trial;
            const dynval::lag_accumulator merged = tree(e, 0, c.n, starts, c.max_lag, gen, c.max_block);
            EXPECT_EQ(merged.n_samples(), c.n);
            EXPECT_EQ(merged.lag_products(), one.lag_products());
            EXPECT_EQ(merged.longest_segment(), one.longest_segment());
            EXPECT_LE(max_abs_diff(merged.result(adjusted), rho_one), 1e-14) << "tree " << trial;
        }
    }
    // n_ℓ = Σ_s max(n_s − ℓ, 0).
    const auto lengths = dynval::segment_lengths(c.starts, c.n);
    for (Index l = 0; l <= c.max_lag; ++l)
        EXPECT_EQ(one.lag_products()[static_cast<std::size_t>(l)], dynval::lag_products(lengths, l));
}

INSTANTIATE_TEST_SUITE_P(
    Streaming, LagAccumulatorCases,
    ::testing::Values(Case{600, 3, 12, {0}, 0.0, 40},                    // one segment
                      Case{600, 3, 12, {0, 150, 151, 170, 400}, 0.0, 40},  // breaks, a 1-row segment
                      Case{900, 2, 30, {0, 300, 310}, 1e7, 60},          // large offset
                      Case{500, 2, 40, {0, 25, 60, 300}, -3e4, 7},       // blocks shorter than max_lag
                      Case{300, 1, 0, {0, 100}, 5.0, 9},                 // lag 0 only
                      Case{250, 4, 60, {0, 10, 20, 30, 90}, 1e7, 3}));   // segments shorter than max_lag

TEST(LagAccumulator, StridedMapInput) {
    // Joint j of sample k at buf[k*row_step + j*col_step]: neither row- nor column-contiguous.
    const Index n = 700, m = 3, row_step = 8, col_step = 2;
    const MatrixXd e = coloured(n, m, 91, 250.0);
    std::vector<double> buf(static_cast<std::size_t>(n * row_step), std::numeric_limits<double>::quiet_NaN());
    for (Index k = 0; k < n; ++k)
        for (Index j = 0; j < m; ++j) buf[static_cast<std::size_t>(k * row_step + j * col_step)] = e(k, j);
    using Strided = Eigen::Map<const MatrixXd, 0, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>>;
    const Strided view(buf.data(), n, m, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>(col_step, row_step));
    ASSERT_EQ(view(5, 2), e(5, 2));
    const std::vector<Index> starts{0, 333};
    std::mt19937_64 gen(5);
    dynval::lag_accumulator acc = tree(view, 0, n, {starts.begin(), starts.end()}, 20, gen, 50);
    EXPECT_LE(max_abs_diff(acc.result(), direct_acf(e, starts, 20, true)), 1e-14);
    // Row-major and column-major contiguous inputs give the same sums.
    const RowMatrix er = e;
    dynval::lag_accumulator a(m, 20), b(m, 20);
    a.update(er.topRows(333)).break_segment().update(er.bottomRows(n - 333));
    b.update(e.topRows(333)).break_segment().update(e.bottomRows(n - 333));
    EXPECT_LE((a.lag_sums() - b.lag_sums()).cwiseAbs().maxCoeff(), 1e-14 * b.lag_sums().cwiseAbs().maxCoeff());
}

TEST(LagAccumulator, LargeOffsetKeepsDigits) {
    // Unit-spread noise on 1e7: sums of raw products would cancel ~14 digits.
    const MatrixXd e = coloured(5000, 2, 17, 1e7);
    const std::vector<Index> starts{0, 1234};
    std::mt19937_64 gen(3);
    const dynval::lag_accumulator acc = tree(e, 0, 5000, {starts.begin(), starts.end()}, 25, gen, 300);
    const MatrixXd direct = direct_acf(e, starts, 25, false);
    EXPECT_LE(max_abs_diff(acc.result(false), direct), 1e-14);
    // The same signal without the offset has the same autocorrelation (to rounding of the input).
    const MatrixXd centred = e.array() - 1e7;
    dynval::lag_accumulator plain(2, 25);
    plain.update(centred.topRows(1234)).break_segment().update(centred.bottomRows(5000 - 1234));
    EXPECT_LE(max_abs_diff(plain.result(false), direct), 1e-12);
}

TEST(LagAccumulator, PortmanteauMatchesOneShot) {
    const MatrixXd e = coloured(800, 2, 23, 3.0);
    const std::vector<long long> segs{0, 500};
    dynval::lag_accumulator acc(2, 15);
    acc.update(e.topRows(260));
    dynval::lag_accumulator rest(2, 15);
    rest.update(e.middleRows(260, 240)).break_segment().update(e.bottomRows(300));
    acc.merge(rest);
    const std::vector<long long> lags{15, 3, 10};
    for (auto which : {dynval::portmanteau_test::ljung_box, dynval::portmanteau_test::box_pierce}) {
        const auto streamed = dynval::portmanteau(acc, lags, 2LL, which);
        const auto direct = dynval::portmanteau(e, lags, 2LL, segs, which);
        EXPECT_EQ(streamed.df, direct.df);
        EXPECT_LE((streamed.statistic - direct.statistic).abs().maxCoeff(), 1e-12 * direct.statistic.abs().maxCoeff());
        EXPECT_LE((streamed.log_pvalue - direct.log_pvalue).abs().maxCoeff(),
                  1e-11 * direct.log_pvalue.abs().maxCoeff());
    }
    // Ljung–Box Q(3) from the direct-loop biased ρ: N(N+2) Σ ρ̂_ℓ²/n_ℓ, n_ℓ = 800 − 2ℓ.
    const MatrixXd rho = direct_acf(e, {0, 500}, 3, false);
    const auto lb = dynval::ljung_box(acc, std::vector<long long>{3});
    for (Index j = 0; j < 2; ++j) {
        double q = 0;
        for (Index l = 1; l <= 3; ++l) q += rho(l, j) * rho(l, j) / static_cast<double>(800 - 2 * l);
        EXPECT_NEAR(lb.statistic(0, j), 800.0 * 802.0 * q, 1e-11 * lb.statistic(0, j));
    }
}

TEST(LagAccumulator, NonFiniteReportsFirstGlobalRow) {
    MatrixXd e = coloured(300, 3, 29);
    e(211, 2) = std::numeric_limits<double>::quiet_NaN();
    e(240, 0) = -std::numeric_limits<double>::infinity();
    dynval::lag_accumulator a(3, 5), b(3, 5);
    a.update(e.topRows(200));
    b.update(e.middleRows(200, 30)).update(e.bottomRows(70));
    a.merge(b);
    ASSERT_TRUE(a.nonfinite().has_value());
    EXPECT_EQ(a.nonfinite()->row, 211);
    EXPECT_EQ(a.nonfinite()->col, 2);
    std::string streamed, direct;
    try {
        a.result();
    } catch (const dynval::input_error& err) {
        EXPECT_EQ(err.kind(), dynval::error_kind::NonFiniteInput);
        streamed = err.what();
    }
    try {
        dynval::autocorrelation(e, 5);
    } catch (const dynval::input_error& err) {
        direct = err.what();
    }
    EXPECT_EQ(streamed, "e has a non-finite value (nan) at row 211, column 2");
    EXPECT_EQ(streamed, direct);
}

TEST(LagAccumulator, ChecksAndDegenerateValues) {
    // Constant joint: nan at every lag, as dynval::autocorrelation.
    MatrixXd e = coloured(60, 2, 31);
    e.col(1).setConstant(1e7 + 0.5);
    dynval::lag_accumulator acc(2, 4);
    acc.update(e.topRows(7)).update(e.bottomRows(53));
    const auto rho = acc.result();
    EXPECT_TRUE(rho.col(1).array().isNaN().all());
    EXPECT_EQ(rho(0, 0), 1.0);
    const auto lb = dynval::ljung_box(acc, std::vector<long long>{4});
    EXPECT_TRUE(std::isnan(lb.statistic(0, 1)) && std::isnan(lb.pvalue(0, 1)));
    EXPECT_FALSE(std::isnan(lb.statistic(0, 0)));

    // Too few samples, then max_lag against the longest segment: the contract's messages.
    dynval::lag_accumulator tiny(1, 0);
    tiny.update(Eigen::VectorXd::Ones(1));
    try {
        tiny.result();
        ADD_FAILURE() << "no error";
    } catch (const dynval::input_error& err) {
        EXPECT_EQ(err.kind(), dynval::error_kind::TooFewSamples);
        EXPECT_STREQ(err.what(), "autocorrelation needs at least 2 samples, got N=1");
    }
    const MatrixXd x = coloured(30, 1, 37);
    dynval::lag_accumulator short_segments(1, 10);
    short_segments.update(x.topRows(10)).break_segment().update(x.bottomRows(20));
    EXPECT_NO_THROW(short_segments.result());
    dynval::lag_accumulator too_long(1, 20);
    too_long.update(x.topRows(10)).break_segment().update(x.bottomRows(20));
    std::string streamed, direct;
    try {
        too_long.result();
    } catch (const dynval::input_error& err) {
        EXPECT_EQ(err.kind(), dynval::error_kind::InvalidParameter);
        streamed = err.what();
    }
    try {
        dynval::autocorrelation(x, 20, true, std::vector<long long>{10, 20});
    } catch (const dynval::input_error& err) {
        direct = err.what();
    }
    EXPECT_EQ(streamed, "max_lag must be an integer with 0 <= max_lag < 20, got 20");
    EXPECT_EQ(streamed, direct);
    EXPECT_THROW(dynval::lag_accumulator(1, -1), dynval::input_error);
}

TEST(LagAccumulator, MergeIntoEmptyAndBreakBeforeRows) {
    // An empty accumulator with a break merged before rows, and an accumulator whose only
    // content is a break: both must separate the ranges on either side.
    const MatrixXd e = coloured(120, 2, 41);
    const MatrixXd expected = direct_acf(e, {0, 50}, 8, true);
    dynval::lag_accumulator first(2, 8), marker(2, 8), second(2, 8);
    first.update(e.topRows(50));
    marker.break_segment();
    second.update(e.bottomRows(70));
    dynval::lag_accumulator total(2, 8);
    total.merge(first).merge(marker).merge(second);
    EXPECT_LE(max_abs_diff(total.result(), expected), 1e-14);
    dynval::lag_accumulator broken(2, 8);
    broken.break_segment();
    broken.update(e.bottomRows(70));
    dynval::lag_accumulator head(2, 8);
    head.update(e.topRows(50)).merge(broken);
    EXPECT_LE(max_abs_diff(head.result(), expected), 1e-14);
    // Without a break the same pieces join into one segment.
    dynval::lag_accumulator joined(2, 8), tail(2, 8);
    joined.update(e.topRows(50)).merge(tail.update(e.bottomRows(70)));
    EXPECT_LE(max_abs_diff(joined.result(), direct_acf(e, {0}, 8, true)), 1e-14);
    // Merging an accumulator with itself: its rows twice, joined.
    dynval::lag_accumulator self(2, 8);
    self.update(e.topRows(50)).merge(self);
    MatrixXd twice(100, 2);
    twice << e.topRows(50), e.topRows(50);
    EXPECT_LE(max_abs_diff(self.result(), direct_acf(twice, {0}, 8, true)), 1e-14);
}

}  // namespace
