// Unit tests of the header-only core. Expected values are closed forms worked by hand, direct
// loops written here independently of the library, or values printed once by independent tools
// (Octave running the lesson's MATLAB code; scipy.stats / mpmath), as noted at each use.
#include <dynval/dynval.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace {

using Eigen::MatrixXd;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
const double inf = std::numeric_limits<double>::infinity();

MatrixXd lesson_meas() {
    MatrixXd t(6, 2);
    t << 1, 2, 2.5, 1.5, 3.2, .7, 4.1, -.4, 4.8, -1.2, 6.1, -2.1;
    return t;
}
MatrixXd lesson_pred() {
    MatrixXd p(6, 2);
    p << 1.1, 1.9, 2.4, 1.6, 3, .9, 4.3, -.5, 4.7, -1, 6, -2.3;
    return p;
}

MatrixXd random_matrix(Eigen::Index rows, Eigen::Index cols, unsigned seed, double offset = 0.0) {
    std::mt19937_64 gen(seed);
    std::normal_distribution<double> normal;
    MatrixXd a(rows, cols);
    for (Eigen::Index i = 0; i < rows; ++i)
        for (Eigen::Index j = 0; j < cols; ++j) a(i, j) = offset + normal(gen) + (i > 0 ? 0.5 * a(i - 1, j) - 0.5 * offset : 0.0);
    return a;
}

// ρ̂(ℓ) of column j by direct long-double sums, the lag kernels' reference: the overall mean,
// products only between rows of the same record (`record(k)`), over the pairs (adjusted, ℓ > 0)
// or over N, divided by the lag-0 value over N.
template <class M, class R>
double direct_rho(const M& e, Eigen::Index j, Eigen::Index lag, bool adjusted, const R& record) {
    const Eigen::Index n = e.rows();
    long double mean = 0, r0 = 0, s = 0;
    for (Eigen::Index k = 0; k < n; ++k) mean += e(k, j);
    mean /= n;
    for (Eigen::Index k = 0; k < n; ++k) r0 += (e(k, j) - mean) * (e(k, j) - mean);
    Eigen::Index pairs = 0;
    for (Eigen::Index k = lag; k < n; ++k) {
        if (record(k) != record(k - lag)) continue;
        s += (e(k, j) - mean) * (e(k - lag, j) - mean);
        ++pairs;
    }
    const long double d = adjusted && lag > 0 ? pairs : n;
    return static_cast<double>((s / d) / (r0 / n));
}

template <class F>
std::string error_message(F f, dynval::error_kind expected) {
    try {
        f();
    } catch (const dynval::input_error& err) {
        EXPECT_EQ(err.kind(), expected) << err.what();
        return err.what();
    }
    ADD_FAILURE() << "no input_error thrown";
    return "";
}

// ------------------------------------------------------------------------------ point metrics

TEST(PointMetrics, LessonExampleMatchesOctave) {
    // Octave 7.3 running the lesson's MATLAB validate_dynamics_model on this data, p = 4
    // (shared build notes, Experiment 2). The lesson's rmse is √(SSE/N): rmse_per_sample.
    const auto r = dynval::compute_metrics(lesson_meas(), lesson_pred(), 4);
    EXPECT_NEAR(r.rmse_per_sample, 0.21213203435596423, 1e-15);
    EXPECT_NEAR(r.vaf_pooled, 99.593588001409231, 1e-12);
    EXPECT_NEAR(r.fit_percent_pooled, 93.615094048676411, 1e-12);
    EXPECT_NEAR(r.r2_pooled, 0.99592329759927523, 1e-14);
    EXPECT_NEAR(r.aic, -37.530879637261158, 1e-12);
    EXPECT_NEAR(r.bic, -35.591253038109159, 1e-12);
    // per_element is the lesson's formula: √(SSE/(N·m)).
    EXPECT_NEAR(r.rmse_per_element, 0.21213203435596423 / std::sqrt(2.0), 1e-15);
}

TEST(PointMetrics, SingleJointClosedForms) {
    // e = [-0.5, 0, 0.5, -0.5]: SSE = 0.75, TSS = 5, Σ(e − ē)² = 0.6875.
    Eigen::VectorXd t(4), p(4);
    t << 1, 2, 3, 4;
    p << 1.5, 2, 2.5, 4.5;
    EXPECT_DOUBLE_EQ(dynval::sse(t, p).value, 0.75);
    EXPECT_DOUBLE_EQ(dynval::rmse(t, p).value, std::sqrt(0.75 / 4));
    EXPECT_DOUBLE_EQ(dynval::max_abs_error(t, p).value, 0.5);
    EXPECT_DOUBLE_EQ(dynval::r2(t, p).value, 1.0 - 0.75 / 5.0);
    EXPECT_DOUBLE_EQ(dynval::fit_percent(t, p).value, 100.0 * (1.0 - std::sqrt(0.75 / 5.0)));
    EXPECT_DOUBLE_EQ(dynval::vaf(t, p).value, 100.0 * (1.0 - 0.6875 / 5.0));
    const Eigen::VectorXd e = t - p;
    EXPECT_DOUBLE_EQ(dynval::residual_mean(e)(0), -0.125);
    EXPECT_DOUBLE_EQ(dynval::residual_variance(e)(0), 0.6875 / 3.0);
    EXPECT_DOUBLE_EQ(dynval::residual_variance(e, 0)(0), 0.6875 / 4.0);
    const auto res = dynval::residuals(t, p);
    EXPECT_EQ(res.rows(), 4);
    EXPECT_DOUBLE_EQ(res(2, 0), 0.5);
}

TEST(PointMetrics, Aggregations) {
    // Joint 0: t = [1,2,3,4], SSE 0.75, TSS 5; joint 1: t = [0,0,2,2], SSE 1, TSS 4.
    MatrixXd t(4, 2), p(4, 2);
    t << 1, 0, 2, 0, 3, 2, 4, 2;
    p << 1.5, 0.5, 2, 0.5, 2.5, 1.5, 4.5, 1.5;
    const auto raw = dynval::r2(t, p, dynval::multioutput::raw_values);
    ASSERT_TRUE(raw.per_joint);
    EXPECT_DOUBLE_EQ(raw.values(0), 0.85);
    EXPECT_DOUBLE_EQ(raw.values(1), 0.75);
    EXPECT_DOUBLE_EQ(dynval::r2(t, p, dynval::multioutput::uniform_average).value, 0.8);
    // variance_weighted = 1 − ΣSSE/ΣTSS when no joint is constant.
    EXPECT_NEAR(dynval::r2(t, p, dynval::multioutput::variance_weighted).value, 1.0 - 1.75 / 9.0, 1e-15);
    // pooled: all 8 values, one mean (1.75): TSS = Σt² − 8·1.75² = 38 − 24.5 = 13.5.
    EXPECT_NEAR(dynval::r2(t, p).value, 1.0 - 1.75 / 13.5, 1e-15);
    EXPECT_DOUBLE_EQ(dynval::sse(t, p, dynval::multioutput::raw_values).values(1), 1.0);
    EXPECT_DOUBLE_EQ(dynval::rmse(t, p, dynval::multioutput::uniform_average).value, 0.5 * (std::sqrt(0.75 / 4) + 0.5));
    EXPECT_DOUBLE_EQ(dynval::rmse(t, p, dynval::multioutput::pooled, dynval::rmse_convention::per_sample).value, std::sqrt(1.75 / 4));
    EXPECT_DOUBLE_EQ(dynval::rmse(t, p).value, std::sqrt(1.75 / 8));
    EXPECT_DOUBLE_EQ(dynval::fit_percent(t, p, dynval::multioutput::raw_values).values(1), 100.0 * (1.0 - std::sqrt(0.25)));
}

TEST(PointMetrics, DegenerateValues) {
    MatrixXd t(3, 2), p(3, 2);
    t << 2, 1, 2, 2, 2, 3;  // joint 0 constant
    p << 2, 1, 2, 2, 2.5, 3.5;
    const auto r2 = dynval::r2(t, p, dynval::multioutput::raw_values).values;
    EXPECT_EQ(r2(0), -inf);
    const auto vw = dynval::r2(t, p, dynval::multioutput::variance_weighted).value;
    EXPECT_DOUBLE_EQ(vw, r2(1));  // the constant joint has weight 0 and is left out
    EXPECT_EQ(dynval::r2(t, p, dynval::multioutput::uniform_average).value, -inf);
    // exact fit of a constant target: nan
    MatrixXd c = MatrixXd::Constant(3, 1, 4.0);
    EXPECT_TRUE(std::isnan(dynval::r2(c, c).value));
    EXPECT_TRUE(std::isnan(dynval::fit_percent(c, c).value));
    EXPECT_TRUE(std::isnan(dynval::vaf(c, c).value));
    // VAF: constant residual counts as exact
    MatrixXd c2 = MatrixXd::Constant(3, 1, 3.0);
    EXPECT_TRUE(std::isnan(dynval::vaf(c, c2).value));
    EXPECT_EQ(dynval::r2(c, c2).value, -inf);
    // all joints constant: variance_weighted is the uniform average
    MatrixXd cc(3, 2), pc(3, 2);
    cc << 1, 5, 1, 5, 1, 5;
    pc << 1, 5, 1, 5, 1, 6;
    const auto per = dynval::r2(cc, pc, dynval::multioutput::raw_values).values;
    EXPECT_TRUE(std::isnan(per(0)));
    EXPECT_EQ(per(1), -inf);
    EXPECT_TRUE(std::isnan(dynval::r2(cc, pc, dynval::multioutput::variance_weighted).value));
    // perfect fit
    const MatrixXd a = lesson_meas();
    const auto r = dynval::compute_metrics(a, a, 2);
    EXPECT_EQ(r.rmse_per_element, 0.0);
    EXPECT_EQ(r.fit_percent_pooled, 100.0);
    EXPECT_EQ(r.r2_pooled, 1.0);
    EXPECT_EQ(r.aic, -inf);
    EXPECT_EQ(r.bic, -inf);
    EXPECT_EQ(r.aicc, -inf);
    EXPECT_EQ(r.fpe, 0.0);
    for (auto model : {dynval::noise_model::per_joint, dynval::noise_model::full})
        EXPECT_EQ(dynval::criteria(a, a, 2, model).aic, -inf);
}

TEST(PointMetrics, LargeOffsetKeepsDigits) {
    // NIST StRD NumAcc4-like: 1e8 + small values; TSS of [1, 2, 3, 4] is exactly 5.
    Eigen::VectorXd t(4), p(4);
    t << 1e8 + 1, 1e8 + 2, 1e8 + 3, 1e8 + 4;
    p << 1e8 + 1.5, 1e8 + 2, 1e8 + 2.5, 1e8 + 4.5;
    EXPECT_DOUBLE_EQ(dynval::r2(t, p).value, 0.85);
    EXPECT_DOUBLE_EQ(dynval::residual_variance(t)(0), 5.0 / 3.0);
    EXPECT_DOUBLE_EQ(dynval::residual_mean(t)(0), 1e8 + 2.5);
}

// ------------------------------------------------------------------------------ layouts

TEST(Layouts, StridedMapsBlocksAndRowMajorAgree) {
    const MatrixXd big = random_matrix(300, 6, 7, 3.0);
    const MatrixXd big2 = big + random_matrix(300, 6, 8) * 0.1;
    // every other row, columns 1..3: a non-contiguous view
    const MatrixXd dense_t = big(Eigen::seq(0, 298, 2), Eigen::seqN(1, 3));
    const MatrixXd dense_p = big2(Eigen::seq(0, 298, 2), Eigen::seqN(1, 3));
    using Stride = Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>;
    Eigen::Map<const MatrixXd, 0, Stride> map_t(big.data() + 300, 150, 3, Stride(300, 2));
    Eigen::Map<const MatrixXd, 0, Stride> map_p(big2.data() + 300, 150, 3, Stride(300, 2));
    const RowMatrix row_t = dense_t, row_p = dense_p;
    const auto ref = dynval::compute_metrics(dense_t, dense_p, 3, 1, dynval::noise_model::full);
    const auto via_map = dynval::compute_metrics(map_t, map_p, 3, 1, dynval::noise_model::full);
    const auto via_row = dynval::compute_metrics(row_t, row_p, 3, 1, dynval::noise_model::full);
    const auto via_block = dynval::compute_metrics(big(Eigen::seq(0, 298, 2), Eigen::seqN(1, 3)),
                                                   big2(Eigen::seq(0, 298, 2), Eigen::seqN(1, 3)), 3, 1,
                                                   dynval::noise_model::full);
    // Strided and block expressions take the generic path and read exactly the same values.
    for (const auto* r : {&via_map, &via_block}) {
        EXPECT_EQ(r->r2_pooled, ref.r2_pooled);
        EXPECT_EQ(r->aic, ref.aic);
        EXPECT_TRUE((r->vaf == ref.vaf).all());
        EXPECT_TRUE((r->residual_variance == ref.residual_variance).all());
    }
    // Contiguous row-major data takes the vectorised one-pass path: same values to rounding.
    EXPECT_NEAR(via_row.r2_pooled, ref.r2_pooled, 1e-15);
    EXPECT_NEAR(via_row.aic, ref.aic, 1e-12 * std::abs(ref.aic));
    EXPECT_TRUE(via_row.vaf.isApprox(ref.vaf, 1e-15));
    EXPECT_TRUE(via_row.residual_variance.isApprox(ref.residual_variance, 1e-14));
    EXPECT_TRUE((via_row.max_abs_error == ref.max_abs_error).all());
    EXPECT_TRUE((via_row.sse - ref.sse).abs().maxCoeff() <= 1e-14 * ref.sse.maxCoeff());
    // The lesson's Map<VectorXd>(data, N*m) flattening would read the wrong elements of map_t;
    // the metrics are order-invariant over the 2-D expression instead.
    const MatrixXd e = dense_t - dense_p;
    const auto acf_dense = dynval::autocorrelation(e, 5);
    const auto acf_map = dynval::autocorrelation(map_t - map_p, 5);
    EXPECT_TRUE(acf_dense.isApprox(acf_map, 1e-15));
    EXPECT_TRUE(dynval::autocorrelation(e.transpose().transpose(), 5).isApprox(acf_dense, 1e-15));
}

// ------------------------------------------------------------------------------ accumulator

TEST(Accumulator, UpdateAndMergeEqualOnePass) {
    const MatrixXd t = random_matrix(1000, 4, 11, 50.0);
    const MatrixXd p = t + random_matrix(1000, 4, 12) * 0.2;
    const auto one = dynval::accumulate(t, p, true);
    dynval::joint_accumulator chunked(4, true);
    for (Eigen::Index start = 0; start < 1000; start += 77) {
        const Eigen::Index n = std::min<Eigen::Index>(77, 1000 - start);
        chunked.update(t.middleRows(start, n), p.middleRows(start, n));
    }
    dynval::joint_accumulator first(4, true), second(4, true);
    first.update(t.topRows(401), p.topRows(401));
    second.update(t.bottomRows(599), p.bottomRows(599));
    first.merge(second);
    for (const auto& acc : {chunked.result(), first.result()}) {
        EXPECT_EQ(acc.n_samples, 1000);
        EXPECT_TRUE(acc.tau_mean.isApprox(one.tau_mean, 1e-15));
        EXPECT_TRUE(acc.tau_m2.isApprox(one.tau_m2, 1e-14));
        EXPECT_TRUE(acc.e_m2.isApprox(one.e_m2, 1e-14));
        EXPECT_TRUE(acc.sse.isApprox(one.sse, 1e-15));
        EXPECT_TRUE((acc.max_abs_e == one.max_abs_e).all());
        EXPECT_TRUE(acc.residual_gram.isApprox(one.residual_gram, 1e-14));
    }
    // Moments against a two-pass computation written here.
    for (int j = 0; j < 4; ++j) {
        const double mean = t.col(j).mean();
        EXPECT_NEAR(one.tau_mean(j), mean, 1e-13);
        EXPECT_NEAR(one.tau_m2(j), (t.col(j).array() - mean).square().sum(), 1e-10 * one.tau_m2(j));
    }
}

TEST(Accumulator, ContiguousPathMatchesGenericPath) {
    // Row counts that leave odd and partial blocks of the vectorised path.
    for (Eigen::Index n : {1, 2, 3, 255, 257, 1001}) {
        const RowMatrix t = random_matrix(n, 5, 40 + static_cast<unsigned>(n), -2e4);
        const RowMatrix p = RowMatrix(t) + RowMatrix(random_matrix(n, 5, 41)) * 0.3;
        const MatrixXd tc = t, pc = p;  // column-major copies take the generic path
        const auto fast = dynval::accumulate(t, p, true);
        const auto generic = dynval::accumulate(tc, pc, true);
        // Means compared on their natural scale (the size of the values), not relative to a
        // mean that may be near zero.
        const MatrixXd ec = tc - pc;
        EXPECT_LE((fast.tau_mean - generic.tau_mean).abs().maxCoeff(), 1e-15 * tc.cwiseAbs().maxCoeff()) << n;
        EXPECT_LE((fast.e_mean - generic.e_mean).abs().maxCoeff(), 1e-15 * ec.cwiseAbs().maxCoeff()) << n;
        EXPECT_TRUE((fast.tau_m2 - generic.tau_m2).abs().maxCoeff() <= 1e-13 * generic.tau_m2.maxCoeff() + 1e-300) << n;
        EXPECT_TRUE((fast.e_m2 - generic.e_m2).abs().maxCoeff() <= 1e-13 * generic.e_m2.maxCoeff() + 1e-300) << n;
        EXPECT_TRUE(fast.sse.isApprox(generic.sse, 1e-14)) << n;
        EXPECT_TRUE((fast.tau_min == generic.tau_min).all() && (fast.e_max == generic.e_max).all()) << n;
        EXPECT_TRUE((fast.max_abs_e == generic.max_abs_e).all()) << n;
        EXPECT_TRUE(fast.residual_gram.isApprox(generic.residual_gram, 1e-14)) << n;
    }
    {
        // Contiguous blocks after a merge into an empty accumulator, on a large offset.
        const RowMatrix t = random_matrix(3000, 2, 60, 1e7);
        const RowMatrix p = RowMatrix(t) + RowMatrix(random_matrix(3000, 2, 61));
        dynval::joint_accumulator empty(2), later(2);
        later.update(t.topRows(1000), p.topRows(1000));
        empty.merge(later);
        empty.update(t.bottomRows(2000), p.bottomRows(2000));
        const MatrixXd tc = t, pc = p;
        const auto generic = dynval::accumulate(tc, pc);
        const auto merged = empty.result();
        EXPECT_TRUE(merged.tau_m2.isApprox(generic.tau_m2, 1e-13));
        EXPECT_TRUE(merged.e_m2.isApprox(generic.e_m2, 1e-13));
    }
    RowMatrix t = random_matrix(600, 3, 50), p = random_matrix(600, 3, 51);
    p(517, 2) = std::numeric_limits<double>::infinity();
    t(530, 0) = std::numeric_limits<double>::quiet_NaN();
    const auto r = dynval::accumulate(t, p);
    ASSERT_TRUE(r.nonfinite_meas && r.nonfinite_pred);
    EXPECT_EQ(r.nonfinite_meas->row, 530);
    EXPECT_EQ(r.nonfinite_pred->row, 517);
    EXPECT_EQ(r.nonfinite_pred->col, 2);
}

// The moments of one signal (update_signal: a residual's or a regressor's) take a lane kernel of
// their own on contiguous rows; they must be those of the signal with a prediction of zeros (the
// fused kernel) bit for bit: odd and partial blocks, a large offset, a merge and a non-finite value.
TEST(Accumulator, SignalPathIsTheZeroPredictionPath) {
    const auto same = [](const Eigen::ArrayXd& u, const Eigen::ArrayXd& v) {
        return ((u == v) || (u.isNaN() && v.isNaN())).all();
    };
    const auto expect_same = [&](const dynval::joint_moments& r, const dynval::joint_moments& w, Eigen::Index n) {
        EXPECT_TRUE(same(r.tau_mean, w.tau_mean) && same(r.tau_m2, w.tau_m2) && same(r.e_m2, w.e_m2)) << n;
        EXPECT_TRUE(same(r.tau_shift, w.tau_shift) && same(r.tau_dev, w.tau_dev) && same(r.e_dev, w.e_dev)) << n;
        EXPECT_TRUE(same(r.sse, w.sse) && same(r.max_abs_e, w.max_abs_e)) << n;
        EXPECT_TRUE(same(r.tau_min, w.tau_min) && same(r.tau_max, w.tau_max)) << n;
        EXPECT_TRUE(same(r.e_min, w.e_min) && same(r.e_max, w.e_max)) << n;
        EXPECT_EQ(r.nonfinite_meas.has_value(), w.nonfinite_meas.has_value()) << n;
    };
    for (Eigen::Index n : {1, 2, 3, 255, 257, 1001}) {
        RowMatrix x = random_matrix(n, 6, 70 + static_cast<unsigned>(n), 1e5);
        if (n == 1001) x(600, 4) = std::numeric_limits<double>::quiet_NaN();
        const RowMatrix zero = RowMatrix::Zero(n, 6);
        const Eigen::Index h = n / 2;
        dynval::joint_accumulator sig(6), fused(6), sig_head(6), sig_tail(6), fused_head(6), fused_tail(6);
        sig.update_signal(x);
        fused.update(x, zero);
        expect_same(sig.result(), fused.result(), n);
        sig_head.update_signal(x.topRows(h));
        sig_tail.update_signal(x.bottomRows(n - h));
        fused_head.update(x.topRows(h), zero.topRows(h));
        fused_tail.update(x.bottomRows(n - h), zero.bottomRows(n - h));
        expect_same(sig_head.merge(sig_tail).result(), fused_head.merge(fused_tail).result(), n);
        if (n == 1001) {
            EXPECT_EQ(sig.result().nonfinite_meas->row, 600);
        }
    }
}

TEST(Accumulator, MergeShiftsNonFiniteRow) {
    MatrixXd t = random_matrix(10, 2, 3), p = random_matrix(10, 2, 4);
    MatrixXd t2 = t;
    t2(3, 1) = std::numeric_limits<double>::quiet_NaN();
    dynval::joint_accumulator a(2), b(2);
    a.update(t, p);
    b.update(t2, p);
    a.merge(b);
    const auto r = a.result();
    ASSERT_TRUE(r.nonfinite_meas.has_value());
    EXPECT_EQ(r.nonfinite_meas->row, 13);
    EXPECT_EQ(r.nonfinite_meas->col, 1);
    EXPECT_FALSE(r.nonfinite_pred.has_value());
}

// ------------------------------------------------------------------------------ correlation

TEST(Correlation, AlternatingSequence) {
    Eigen::VectorXd e(4);
    e << 1, -1, 1, -1;  // mean 0, R(0) = 1
    const auto adj = dynval::autocorrelation(e, 2);
    EXPECT_DOUBLE_EQ(adj(0, 0), 1.0);
    EXPECT_DOUBLE_EQ(adj(1, 0), -1.0);
    EXPECT_DOUBLE_EQ(adj(2, 0), 1.0);
    const auto biased = dynval::autocorrelation(e, 2, false);
    EXPECT_DOUBLE_EQ(biased(1, 0), -0.75);
    EXPECT_DOUBLE_EQ(biased(2, 0), 0.5);
}

TEST(Correlation, LessonWolframValues) {
    // The lesson's residualAutocorrelation run in Mathics3 on e = τ − τ̂ of its scalar example
    // (shared build notes, Experiment 4).
    Eigen::VectorXd t(6), p(6);
    t << 1.0, 2.5, 3.2, 4.1, 4.8, 6.1;
    p << 1.1, 2.4, 3.0, 4.3, 4.7, 6.0;
    const auto rho = dynval::autocorrelation(t - p, 3);
    EXPECT_NEAR(rho(1, 0), -0.5058823529411766, 1e-14);
    EXPECT_NEAR(rho(2, 0), -0.5588235294117652, 1e-14);
    EXPECT_NEAR(rho(3, 0), 0.8235294117647051, 1e-14);
}

TEST(Correlation, SegmentsAgainstDirectLoop) {
    const MatrixXd e = random_matrix(40, 2, 21);
    const std::vector<long long> lengths{15, 25};
    const auto rho = dynval::autocorrelation(e, 6, true, lengths);
    const auto rho_starts = dynval::autocorrelation(e, 6, true, std::vector<long long>{0, 15});
    EXPECT_TRUE(rho.isApprox(rho_starts, 0.0));
    for (int j = 0; j < 2; ++j) {
        const double mean = e.col(j).mean();
        double r0 = 0;
        for (int k = 0; k < 40; ++k) r0 += (e(k, j) - mean) * (e(k, j) - mean);
        r0 /= 40;
        for (int lag = 1; lag <= 6; ++lag) {
            double s = 0;
            int count = 0;
            for (int k = 0; k < 40; ++k) {
                const int seg = k < 15 ? 0 : 1, seg_prev = (k - lag) < 15 ? 0 : 1;
                if (k - lag < 0 || seg != seg_prev) continue;
                s += (e(k, j) - mean) * (e(k - lag, j) - mean);
                ++count;
            }
            EXPECT_NEAR(rho(lag, j), (s / count) / r0, 1e-13);
        }
    }
}

TEST(Correlation, RowMajorBlockedPathAgainstDirectLoop) {
    // C-contiguous data takes the blocked path; lags beyond one block (512 rows) and a segment
    // break inside a block exercise the carried tail rows.
    const Eigen::Index n = 1500;
    const RowMatrix e = random_matrix(n, 3, 71, 5.0);
    const std::vector<long long> lengths{1100, 400};
    const Eigen::Index lags = 700;
    const auto rho = dynval::autocorrelation(e, lags, false, lengths);
    const MatrixXd ec = e;
    const auto rho_generic = dynval::autocorrelation(ec, lags, false, lengths);
    for (int j = 0; j < 3; ++j) {
        const double mean = e.col(j).mean();
        double r0 = 0;
        for (Eigen::Index k = 0; k < n; ++k) r0 += (e(k, j) - mean) * (e(k, j) - mean);
        for (Eigen::Index lag : {1, 7, 511, 512, 513, 699, 700}) {
            double s = 0;
            for (Eigen::Index k = lag; k < n; ++k) {
                if ((k < 1100) != (k - lag < 1100)) continue;
                s += (e(k, j) - mean) * (e(k - lag, j) - mean);
            }
            EXPECT_NEAR(rho(lag, j), s / r0, 1e-13) << lag;
            EXPECT_NEAR(rho_generic(lag, j), s / r0, 1e-13) << lag;
        }
    }
}

TEST(Correlation, ConstantResidualIsNan) {
    MatrixXd e(5, 2);
    e << 1, 0.3, 2, 0.3, 3, 0.3, 1, 0.3, 0, 0.3;
    const auto rho = dynval::autocorrelation(e, 2);
    EXPECT_EQ(rho(0, 0), 1.0);
    EXPECT_TRUE(std::isnan(rho(0, 1)) && std::isnan(rho(2, 1)));
    const auto lb = dynval::ljung_box(e, std::vector<long long>{2});
    EXPECT_TRUE(std::isnan(lb.statistic(0, 1)) && std::isnan(lb.pvalue(0, 1)));
}

TEST(Correlation, CrossCorrelationStaysWithinItsBound) {
    // y = -0.012·e - 1.259 (a perfectly correlated column): the rounding of the sums gave
    // rho = -1.0000000000000002; Cauchy-Schwarz bounds |rho(0)| by 1 (contract §3.6).
    MatrixXd e(7, 1);
    e << 0.321, -0.818, 0.732, -0.501, 0.879, -1.072, 0.914;
    RowMatrix y(7, 1);
    y << -1.2554200000000002, -1.2326400000000002, -1.26364, -1.2389800000000002, -1.26658,
        -1.2275600000000002, -1.2672800000000002;
    for (const bool adjusted : {true, false}) {
        const auto cc = dynval::cross_correlation(e, y, 1, 3, adjusted);
        EXPECT_EQ(cc.rho(0, 0), -1.0);
        for (Eigen::Index lag = 1; lag <= 3; ++lag)
            EXPECT_LE(std::abs(cc.rho(0, lag)), adjusted ? 7.0 / static_cast<double>(7 - lag) : 1.0);
    }
}

TEST(Correlation, CrossCorrelationAgainstDirectLoop) {
    const Eigen::Index n = 50, m = 2, p = 3;
    const MatrixXd e = random_matrix(n, m, 31);
    RowMatrix y = random_matrix(n, m * p, 32);
    y.col(4).setConstant(2.0);  // joint 1, column 1 constant
    const auto cc = dynval::cross_correlation(e, y, p, 4, false);
    EXPECT_TRUE(cc.constant_mask[4]);
    EXPECT_FALSE(cc.constant_mask[3]);
    EXPECT_TRUE(std::isnan(cc.rho(4, 0)));
    for (Eigen::Index j = 0; j < m; ++j)
        for (Eigen::Index c = 0; c < p; ++c) {
            const Eigen::Index q = j * p + c;
            if (q == 4) continue;
            const double me = e.col(j).mean(), my = y.col(q).mean();
            const double re0 = (e.col(j).array() - me).square().sum() / n;
            const double ry0 = (y.col(q).array() - my).square().sum() / n;
            for (int lag = 0; lag <= 4; ++lag) {
                double s = 0;
                for (Eigen::Index k = lag; k < n; ++k) s += (e(k, j) - me) * (y(k - lag, q) - my);
                EXPECT_NEAR(cc.rho(q, lag), (s / n) / std::sqrt(re0 * ry0), 1e-13);
            }
        }
}

// Row-major regressors take the register-tiled path (6 lags x 8 columns, blocks of 128 rows,
// compensated every 1024); column-major ones the dot product per lag. Both must equal direct
// long-double sums: lags and columns that are not multiples of the tile, a segment boundary, a
// constant column, and a joint with a column near 1e-170 (scaled, so that joint is not tiled).
TEST(Correlation, TiledCrossCorrelationAgainstDirectSums) {
    const Eigen::Index n = 2600, m = 3, p = 11, max_lag = 9;
    const MatrixXd e = random_matrix(n, m, 41);
    RowMatrix y = random_matrix(n, m * p, 42);
    y.col(3).setConstant(-1.5);
    y.col(2 * p + 5) *= 1e-170;
    const Eigen::MatrixXd y_col_major = y;
    const std::vector<long long> lengths{1000, 1600};
    const auto tiled = dynval::cross_correlation(e, y, p, max_lag, true, lengths);
    const auto direct = dynval::cross_correlation(e, y_col_major, p, max_lag, true, lengths);
    for (Eigen::Index j = 0; j < m; ++j)
        for (Eigen::Index c = 0; c < p; ++c) {
            const Eigen::Index q = j * p + c;
            if (q == 3) {
                EXPECT_TRUE(tiled.constant_mask[3] && std::isnan(tiled.rho(3, 0)));
                continue;
            }
            long double me = 0, my = 0;
            for (Eigen::Index k = 0; k < n; ++k) {
                me += e(k, j);
                my += y(k, q);
            }
            me /= n;
            my /= n;
            long double re0 = 0, ry0 = 0;
            for (Eigen::Index k = 0; k < n; ++k) {
                re0 += (e(k, j) - me) * (e(k, j) - me);
                ry0 += (y(k, q) - my) * (y(k, q) - my);
            }
            for (Eigen::Index lag = 0; lag <= max_lag; ++lag) {
                long double s = 0;
                Eigen::Index products = 0;
                for (Eigen::Index k = lag; k < n; ++k) {
                    if ((k < 1000) != (k - lag < 1000)) continue;  // never across the segments
                    s += (e(k, j) - me) * (y(k - lag, q) - my);
                    ++products;
                }
                const double want = static_cast<double>((s / products) / std::sqrt(re0 / n * ry0 / n));
                EXPECT_NEAR(tiled.rho(q, lag), want, 1e-14) << "joint " << j << " column " << c << " lag " << lag;
                EXPECT_NEAR(direct.rho(q, lag), want, 1e-14) << "joint " << j << " column " << c << " lag " << lag;
            }
        }
}

// A serial arm's regressor: joint j's columns of the links before it are zero. The tiled kernel
// multiplies only the columns that vary; the others are nan, and every varying column's ρ is the
// one it has beside varying columns in their place (bit for bit: a column's sums do not depend on
// its place in the packed panels), also for a joint all of whose columns are constant and for
// more than 8 live columns (two panels) beside a partial panel.
TEST(Correlation, TiledCrossCorrelationSkipsConstantColumns) {
    const Eigen::Index n = 1500, m = 4, p = 13, max_lag = 8;
    const MatrixXd e = random_matrix(n, m, 81);
    const RowMatrix full = random_matrix(n, m * p, 82);
    RowMatrix arm = full;
    for (Eigen::Index j = 0; j < m; ++j)
        for (Eigen::Index c = 0; c < 3 * j; ++c) arm.col(j * p + c).setZero();
    arm.col(2 * p + 10).setConstant(0.25);  // a constant column among the varying ones
    for (Eigen::Index c = 0; c < p; ++c) arm.col(3 * p + c).setConstant(c == 0 ? 0.0 : 2.0);  // joint 3: none varies
    const std::vector<long long> lengths{600, 900};
    const auto skipped = dynval::cross_correlation(e, arm, p, max_lag, true, lengths);
    const auto every = dynval::cross_correlation(e, full, p, max_lag, true, lengths);
    Eigen::Index varying = 0;
    for (Eigen::Index j = 0; j < m; ++j)
        for (Eigen::Index c = 0; c < p; ++c) {
            const Eigen::Index q = j * p + c;
            const bool constant = j == 3 || c < 3 * j || q == 2 * p + 10;
            EXPECT_EQ(skipped.constant_mask[static_cast<std::size_t>(q)], constant) << "column " << q;
            for (Eigen::Index lag = 0; lag <= max_lag; ++lag) {
                if (constant) {
                    EXPECT_TRUE(std::isnan(skipped.rho(q, lag))) << "column " << q << " lag " << lag;
                } else {
                    EXPECT_EQ(skipped.rho(q, lag), every.rho(q, lag)) << "column " << q << " lag " << lag;
                }
            }
            varying += constant ? 0 : 1;
        }
    EXPECT_EQ(varying, p + (p - 3) + (p - 7));
}

// Above about 1e8 multiply-adds the tiled cross-correlation splits the joints over threads: the
// result is bit for bit the one-thread result whatever the split (each joint's sums are formed by
// one thread in the same order), and equals the per-lag dot products of a column-major regressor.
TEST(Correlation, ThreadedCrossCorrelationIsTheOneThreadResult) {
    const Eigen::Index n = 40000, m = 5, p = 25, max_lag = 20;  // 1.05e8 multiply-adds
    const MatrixXd e = random_matrix(n, m, 61);
    const RowMatrix y = random_matrix(n, m * p, 62);
    const std::vector<long long> lengths{15000, 25000};
    const auto with_threads = [&](const char* count) {
        setenv("DYNVAL_NUM_THREADS", count, 1);
        auto r = dynval::cross_correlation(e, y, p, max_lag, true, lengths);
        unsetenv("DYNVAL_NUM_THREADS");
        return r;
    };
    EXPECT_EQ(dynval::detail::worker_count(m, 1.05e8), dynval::detail::worker_count(m, 2e8));
    setenv("DYNVAL_NUM_THREADS", "3", 1);
    EXPECT_EQ(dynval::detail::worker_count(m, 1.05e8), 3);
    EXPECT_EQ(dynval::detail::worker_count(m, 1e6), 1);  // too little work to start a thread
    EXPECT_EQ(dynval::detail::worker_count(2, 1e9), 2);  // never more threads than items
    unsetenv("DYNVAL_NUM_THREADS");
    const auto one = with_threads("1");
    const Eigen::MatrixXd y_col_major = y;
    const auto direct = dynval::cross_correlation(e, y_col_major, p, max_lag, true, lengths);
    for (const char* count : {"2", "3", "5", "8"}) {
        const auto many = with_threads(count);
        EXPECT_TRUE((many.rho.array() == one.rho.array()).all()) << count << " threads";
    }
    EXPECT_LT((one.rho - direct.rho).cwiseAbs().maxCoeff(), 1e-14);
}

// A regressor of 2^24 values or more has its moments from two halves of rows, merged (one thread
// each): the same moments as one pass to rounding, the same whatever the thread count, and the
// first non-finite value of the second half at its row in the whole.
TEST(Correlation, RegressorMomentsFromTwoHalves) {
    const Eigen::Index n = 70000, cols = 240;  // 1.68e7 values
    RowMatrix y = random_matrix(n, cols, 71);
    y.col(5).array() += 1e6;
    const Eigen::Ref<const RowMatrix> ref(y);
    setenv("DYNVAL_NUM_THREADS", "1", 1);
    const auto one = dynval::detail::accumulate_signal_halves(ref);
    setenv("DYNVAL_NUM_THREADS", "2", 1);
    const auto two = dynval::detail::accumulate_signal_halves(ref);
    unsetenv("DYNVAL_NUM_THREADS");
    const auto whole = dynval::accumulate_signal(ref);
    EXPECT_TRUE((one.tau_m2 == two.tau_m2).all() && (one.tau_mean == two.tau_mean).all());
    EXPECT_LT(((one.tau_m2 - whole.tau_m2) / whole.tau_m2).abs().maxCoeff(), 1e-13);
    EXPECT_LT((one.tau_mean - whole.tau_mean).abs().maxCoeff(), 1e-9);  // 1e6 offset on column 5
    EXPECT_TRUE((one.tau_min == whole.tau_min).all() && (one.tau_max == whole.tau_max).all());
    EXPECT_EQ(one.n_samples, n);
    y(60000, 17) = std::numeric_limits<double>::quiet_NaN();
    y(50000, 200) = inf;
    const auto bad = dynval::detail::accumulate_signal_halves(Eigen::Ref<const RowMatrix>(y));
    ASSERT_TRUE(bad.nonfinite_meas.has_value());
    EXPECT_EQ(bad.nonfinite_meas->row, 50000);
    EXPECT_EQ(bad.nonfinite_meas->col, 200);
}

// The regressor's moments computed once (regressor_moments) and given to later calls: bit for bit
// the call that computes them, tiled (row-major) and direct (column-major) paths alike, constant
// columns included; moments of another shape are refused, and with them a non-finite value.
TEST(Correlation, GivenRegressorMomentsGiveTheSameResult) {
    const Eigen::Index n = 3000, m = 3, p = 4, max_lag = 9;
    const MatrixXd e = random_matrix(n, m, 81);
    RowMatrix y = random_matrix(n, m * p, 82);
    y.col(2).setConstant(3.5);
    const std::vector<long long> lengths{1000, 2000};
    const Eigen::MatrixXd y_col_major = y;
    for (bool adjusted : {true, false}) {
        const auto kept = dynval::regressor_moments(y);
        const auto a = dynval::cross_correlation(e, y, p, max_lag, adjusted, lengths);
        const auto b = dynval::cross_correlation(e, y, p, max_lag, adjusted, lengths, &kept);
        EXPECT_TRUE((a.rho.array() == b.rho.array() || (a.rho.array().isNaN() && b.rho.array().isNaN())).all());
        EXPECT_EQ(a.constant_mask, b.constant_mask);
        const auto c = dynval::cross_correlation(e, y_col_major, p, max_lag, adjusted, lengths);
        const auto kept_col = dynval::regressor_moments(y_col_major);
        const auto d = dynval::cross_correlation(e, y_col_major, p, max_lag, adjusted, lengths, &kept_col);
        EXPECT_TRUE((c.rho.array() == d.rho.array() || (c.rho.array().isNaN() && d.rho.array().isNaN())).all());
    }
    const auto kept = dynval::regressor_moments(y);
    const RowMatrix shorter = y.topRows(n - 1);
    const MatrixXd e_short = e.topRows(n - 1);
    EXPECT_THROW(dynval::cross_correlation(e_short, shorter, p, 2, true, {}, &kept), dynval::shape_mismatch);
    RowMatrix bad = y;
    bad(10, 5) = inf;
    const auto bad_moments = dynval::regressor_moments(bad);
    EXPECT_THROW(dynval::cross_correlation(e, y, p, 2, true, {}, &bad_moments), dynval::non_finite_input);
}

// Past 1e8 multiply-adds the wide autocorrelation splits its tiles of 7 lags over threads (the
// last thread also takes the lags after the last whole tile): bit for bit the one-thread result.
TEST(Correlation, ThreadedWideAutocorrelationIsTheOneThreadResult) {
    const Eigen::Index n = 100000, m = 40, max_lag = 26;  // 1.08e8 multiply-adds; 3 tiles + 6 lags
    const RowMatrix e = random_matrix(n, m, 81);
    const std::vector<long long> lengths{37001, 62999};
    setenv("DYNVAL_NUM_THREADS", "1", 1);
    const auto one = dynval::autocorrelation(e, max_lag, true, lengths);
    for (const char* count : {"2", "3", "4", "7"}) {
        setenv("DYNVAL_NUM_THREADS", count, 1);
        const auto many = dynval::autocorrelation(e, max_lag, true, lengths);
        EXPECT_TRUE((many.array() == one.array()).all()) << count << " threads";
    }
    unsetenv("DYNVAL_NUM_THREADS");
    const Eigen::MatrixXd col_major = e;  // the per-column dot products
    EXPECT_LT((dynval::autocorrelation(col_major, max_lag, true, lengths) - one).cwiseAbs().maxCoeff(), 1e-14);
}

// Wide row-major data (m >= 16, the regressor's columns) take the register-tiled autocorrelation:
// equal to direct long-double sums with a column count and lag count off the tiles, blocks of 512
// rows and records that start inside a block.
TEST(Correlation, WideAutocorrelationAgainstDirectSums) {
    const Eigen::Index n = 1300, m = 19, max_lag = 10;
    RowMatrix e = random_matrix(n, m, 51);
    e.col(7).setConstant(0.25);
    const std::vector<long long> lengths{300, 530, 470};
    for (const bool adjusted : {true, false}) {
        const auto rho = dynval::autocorrelation(e, max_lag, adjusted, lengths);
        const auto record = [&](Eigen::Index k) { return k < 300 ? 0 : (k < 830 ? 1 : 2); };
        for (Eigen::Index j = 0; j < m; ++j) {
            if (j == 7) {
                EXPECT_TRUE(std::isnan(rho(0, 7)) && std::isnan(rho(max_lag, 7)));
                continue;
            }
            for (Eigen::Index lag = 0; lag <= max_lag; ++lag)
                EXPECT_NEAR(rho(lag, j), direct_rho(e, j, lag, adjusted, record), 1e-14)
                    << "column " << j << " lag " << lag;
        }
    }
}

// Narrow row-major data (up to 15 joints, the residual) take tiles of 8 lags over 4 rows at a time,
// lag by lag before a segment's rows reach the tile's last lag: equal to direct long-double sums
// with row counts off the 4-row step, a lag count off the tile (20 = 8 + 8 + 4), a segment shorter
// than the lags, segments that straddle the 512-row blocks, an offset and 1, 7 and 15 joints.
TEST(Correlation, NarrowAutocorrelationAgainstDirectSums) {
    const Eigen::Index n = 1603, max_lag = 19;
    const std::vector<long long> lengths{601, 9, 993};
    const auto record = [](Eigen::Index k) { return k < 601 ? 0 : (k < 610 ? 1 : 2); };
    for (const Eigen::Index m : {1, 7, 15}) {
        const RowMatrix e = random_matrix(n, m, 91 + static_cast<unsigned>(m), 3.0);
        for (const bool adjusted : {true, false}) {
            const auto rho = dynval::autocorrelation(e, max_lag, adjusted, lengths);
            for (Eigen::Index j = 0; j < m; ++j)
                for (Eigen::Index lag = 0; lag <= max_lag; ++lag)
                    EXPECT_NEAR(rho(lag, j), direct_rho(e, j, lag, adjusted, record), 1e-14)
                        << m << " joints, joint " << j << " lag " << lag;
        }
    }
}

TEST(Correlation, PortmanteauFromHandComputedRho) {
    Eigen::VectorXd e(4);
    e << 1, -1, 1, -1;  // biased ρ1 = −0.75, ρ2 = 0.5
    const auto lb = dynval::ljung_box(e, std::vector<long long>{1, 2});
    EXPECT_NEAR(lb.statistic(0, 0), 4.0 * 6.0 * (0.5625 / 3.0), 1e-13);
    EXPECT_NEAR(lb.statistic(1, 0), 4.0 * 6.0 * (0.5625 / 3.0 + 0.25 / 2.0), 1e-13);
    const auto bp = dynval::box_pierce(e, std::vector<long long>{2}, 1);
    EXPECT_NEAR(bp.statistic(0, 0), 4.0 * (0.5625 + 0.25), 1e-13);
    EXPECT_EQ(bp.df[0], 1);
    // χ²(1) survival at 3.25 from scipy.stats.chi2.sf(3.25, 1) = 0.07142810382121...
    EXPECT_NEAR(bp.pvalue(0, 0), dynval::chi2_sf(3.25, 1), 0.0);
}

TEST(Distributions, ChiSquareAgainstScipyAndMpmath) {
    // scipy.stats.chi2.sf / logsf (scipy 1.17.1), printed once.
    struct Case { double q, df, sf, logsf; };
    const Case cases[] = {{3.0, 1, 0.08326451666355042, -2.4857327909860794},
                          {10.0, 5, 0.07523524614651217, -2.5871354590744855},
                          {150.0, 100, 0.0009039320423540184, -7.008756374784982},
                          {1400.0, 23, 6.286665998950102e-282, -647.4905653419952},
                          {0.5, 200, 1.0, -5.2059487067097426e-219}};
    for (const auto& c : cases) {
        EXPECT_NEAR(dynval::chi2_sf(c.q, c.df), c.sf, 1e-12 * c.sf) << c.q << " " << c.df;
        EXPECT_NEAR(dynval::chi2_logsf(c.q, c.df), c.logsf, 1e-12 * std::abs(c.logsf)) << c.q << " " << c.df;
    }
    // Where the p-value underflows: mpmath (50 digits) log(gammainc(df/2, q/2, inf, regularized)).
    const Case deep[] = {{1e5, 10, 0, -49959.898860691106835},
                         {3000.0, 3, 0, -1496.2222744019926869},
                         {2e4, 200, 0, -9447.300560222770135}};
    for (const auto& c : deep) {
        EXPECT_EQ(dynval::chi2_sf(c.q, c.df), 0.0);
        EXPECT_NEAR(dynval::chi2_logsf(c.q, c.df), c.logsf, 1e-12 * std::abs(c.logsf));
    }
    // scipy.stats.norm.ppf(0.975) = 1.959963984540054
    EXPECT_NEAR(dynval::confidence_band(100), 1.959963984540054 / 10.0, 1e-15);
    EXPECT_NEAR(dynval::confidence_band(1, 0.99), 2.5758293035489004, 1e-14);
}

// ------------------------------------------------------------------------------ criteria

TEST(Criteria, ClosedForms) {
    const auto ic = dynval::information_criteria(2.0, 10, 2);
    EXPECT_DOUBLE_EQ(ic.aic, 4.0 + 10.0 * std::log(0.2));
    EXPECT_DOUBLE_EQ(ic.bic, 2.0 * std::log(10.0) + 10.0 * std::log(0.2));
    EXPECT_DOUBLE_EQ(ic.aicc, ic.aic + 12.0 / 7.0);
    EXPECT_DOUBLE_EQ(ic.fpe, 0.2 * 1.2 / 0.8);
    EXPECT_DOUBLE_EQ(ic.naic, std::log(0.2) + 0.4);
    const auto zero = dynval::information_criteria(0.0, 10, 2);
    EXPECT_EQ(zero.aic, -inf);
    EXPECT_EQ(zero.fpe, 0.0);
}

TEST(Criteria, NoiseModels) {
    const MatrixXd t = lesson_meas(), p = lesson_pred();
    const MatrixXd e = t - p;
    const double n = 6.0;
    const double s00 = e.col(0).squaredNorm(), s11 = e.col(1).squaredNorm(), s01 = e.col(0).dot(e.col(1));
    const auto pj = dynval::criteria(t, p, 3, dynval::noise_model::per_joint);
    EXPECT_NEAR(pj.aic, n * (std::log(s00 / n) + std::log(s11 / n)) + 6.0, 1e-12);
    EXPECT_EQ(pj.n_obs, 6);
    const auto full = dynval::criteria(t, p, 3, dynval::noise_model::full);
    const double det = (s00 * s11 - s01 * s01) / (n * n);
    EXPECT_NEAR(full.aic, n * std::log(det) + 6.0, 1e-12);
    EXPECT_NEAR(full.bic, n * std::log(det) + 3.0 * std::log(n), 1e-12);
    EXPECT_NEAR(full.fpe, det * (1.0 + 0.5) / (1.0 - 0.5), 1e-15);
    EXPECT_NEAR(full.naic, std::log(det) + 1.0, 1e-13);
    // one joint: every noise model is the same
    const auto a = dynval::criteria(t.col(0), p.col(0), 1, dynval::noise_model::pooled);
    const auto b = dynval::criteria(t.col(0), p.col(0), 1, dynval::noise_model::full);
    EXPECT_NEAR(a.aic, b.aic, 1e-12);
    // p >= n − 1: aicc and fpe undefined, not an error, in criteria
    const auto wide = dynval::criteria(t, p, 5, dynval::noise_model::full);
    EXPECT_TRUE(std::isnan(wide.aicc) && std::isnan(wide.fpe));
}

// ------------------------------------------------------------------------------ errors

TEST(Errors, EveryKindWithContractMessages) {
    using K = dynval::error_kind;
    const MatrixXd a = lesson_meas(), b = lesson_pred();
    const MatrixXd empty(6, 0);
    EXPECT_EQ(error_message([&] { dynval::r2(empty, empty); }, K::InvalidShape),
              "tau_meas must have at least one column, got shape (6, 0)");
    EXPECT_EQ(error_message([&] { dynval::r2(a, b.topRows(5)); }, K::ShapeMismatch),
              "tau_meas and tau_pred must have the same shape, got (6, 2) and (5, 2)");
    EXPECT_EQ(error_message([&] { dynval::r2(a.topRows(1), b.topRows(1)); }, K::TooFewSamples),
              "r2 needs at least 2 samples, got N=1");
    MatrixXd bad_t = a, bad_p = b;
    bad_p(1, 0) = -inf;
    bad_t(4, 1) = std::numeric_limits<double>::quiet_NaN();
    EXPECT_EQ(error_message([&] { dynval::sse(a, bad_p); }, K::NonFiniteInput),
              "tau_pred has a non-finite value (-inf) at row 1, column 0");
    // tau_meas is checked before tau_pred, whatever the rows
    EXPECT_EQ(error_message([&] { dynval::sse(bad_t, bad_p); }, K::NonFiniteInput),
              "tau_meas has a non-finite value (nan) at row 4, column 1");
    // finiteness is checked before parameters
    EXPECT_EQ(error_message([&] { dynval::sse(bad_t, b, static_cast<dynval::multioutput>(9)); }, K::NonFiniteInput).substr(0, 8), "tau_meas");
    // An enum cast from an integer outside it is refused, showing the integer.
    EXPECT_EQ(error_message([&] { dynval::r2(a, b, static_cast<dynval::multioutput>(7)); }, K::InvalidParameter),
              "multioutput must be one of 'pooled', 'raw_values', 'uniform_average', 'variance_weighted', got 7");
    // Options read as text go through option_from_name, which names the bad text.
    EXPECT_EQ(error_message([&] { dynval::option_from_name<dynval::multioutput>("nope", "multioutput"); },
                            K::InvalidParameter),
              "multioutput must be one of 'pooled', 'raw_values', 'uniform_average', 'variance_weighted', got 'nope'");
    EXPECT_EQ(dynval::option_from_name<dynval::noise_model>("per_joint", "noise_model"), dynval::noise_model::per_joint);
    EXPECT_EQ(error_message([&] { dynval::sse(a, b, dynval::multioutput::variance_weighted); }, K::InvalidParameter),
              "multioutput must be one of 'pooled', 'raw_values' for sse, got 'variance_weighted'");
    EXPECT_EQ(error_message([&] { dynval::rmse(a, b, dynval::multioutput::raw_values, dynval::rmse_convention::per_sample); },
                            K::InvalidParameter),
              "convention must be None unless multioutput='pooled', got 'per_sample'");
    EXPECT_EQ(error_message([&] { dynval::residual_variance(a, 6); }, K::InvalidParameter),
              "ddof must be an integer with 0 <= ddof < N=6, got 6");
    EXPECT_EQ(error_message([&] { dynval::autocorrelation(a, 6); }, K::InvalidParameter),
              "max_lag must be an integer with 0 <= max_lag < 6, got 6");
    EXPECT_EQ(error_message([&] { dynval::autocorrelation(a, 1, true, std::vector<long long>{4, 3}); },
                            K::InvalidParameter),
              "segments must be positive lengths summing to N=6, or increasing starts beginning at 0 and below "
              "N=6, got [4, 3]");
    EXPECT_EQ(error_message([&] { dynval::ljung_box(a, std::vector<long long>{2, 6}); }, K::InvalidParameter),
              "lags must be a positive integer or a non-empty sequence of positive integers less than 6, got [2, 6]");
    EXPECT_EQ(error_message([&] { dynval::ljung_box(a, std::vector<long long>{2, 3}, 2); }, K::InvalidParameter),
              "model_df must be an integer with 0 <= model_df < 2, got 2");
    EXPECT_EQ(error_message([&] { dynval::criteria(a, b, -1); }, K::InvalidParameter),
              "n_params must be an integer with n_params >= 0, got -1");
    EXPECT_EQ(error_message([&] { dynval::criteria(a, b, 1, static_cast<dynval::noise_model>(-1)); },
                            K::InvalidParameter),
              "noise_model must be one of 'pooled', 'per_joint', 'full', got -1");
    EXPECT_EQ(error_message([&] { dynval::information_criteria(-0.5, 10, 1); }, K::InvalidParameter),
              "rss must be a finite number >= 0, got -0.5");
    EXPECT_EQ(error_message([&] { dynval::information_criteria(1.0, 10, 9); }, K::InvalidParameter),
              "n_params must be less than n_obs - 1 = 9, got 9");
    EXPECT_EQ(error_message([&] { dynval::confidence_band(10, 1.0); }, K::InvalidParameter),
              "level must be a number with 0 < level < 1, got 1");
    EXPECT_EQ(error_message([&] { dynval::confidence_band(10, std::nan("")); }, K::InvalidParameter),
              "level must be a number with 0 < level < 1, got nan");
    EXPECT_EQ(error_message([&] { dynval::cross_correlation(a, a, 2, 1); }, K::InvalidParameter),
              "n_columns must be a positive integer with m*n_columns = 2, got 2");
    // InvalidType cannot arise from typed Eigen input; the kind and its name still exist for
    // the bindings and ports.
    const dynval::invalid_type type_error("tau_meas must be an array of real numbers, got complex128");
    EXPECT_EQ(type_error.kind(), K::InvalidType);
    EXPECT_STREQ(dynval::kind_name(K::InvalidType), "InvalidType");
    EXPECT_NE(dynamic_cast<const std::invalid_argument*>(&type_error), nullptr);
}

TEST(Errors, ValuesInMessages) {
    // The shortest text that reads back as the same double; C++ spelling, not Python's.
    EXPECT_EQ(dynval::value_text(0.1), "0.1");
    EXPECT_EQ(dynval::value_text(3.0), "3");
    EXPECT_EQ(dynval::value_text(-0.0), "-0");
    EXPECT_EQ(dynval::value_text(std::numeric_limits<double>::quiet_NaN()), "nan");
    EXPECT_EQ(dynval::value_text(-inf), "-inf");
    // Out-of-range data (|x| > 1e144) are written as Python writes them: the NonFiniteInput
    // message is the same from every backend.
    EXPECT_EQ(dynval::value_text(1e145), "1e+145");
    EXPECT_EQ(dynval::value_text(-1.5e300), "-1.5e+300");
    EXPECT_EQ(dynval::value_text(1.7976931348623157e308), "1.7976931348623157e+308");
    EXPECT_EQ(dynval::value_text(std::vector<long long>{2, -6}), "[2, -6]");
    EXPECT_EQ(dynval::value_text(-9223372036854775807LL - 1), "-9223372036854775808");
    MatrixXd a = lesson_meas();
    a(2, 1) = 2.5e200;
    EXPECT_EQ(error_message([&] { dynval::residual_mean(a); }, dynval::error_kind::NonFiniteInput),
              "e has a value out of range (2.5e+200) at row 2, column 1: |x| must be at most 1e+144");
    // InvalidParameter keeps its parts for the bindings.
    try {
        dynval::autocorrelation(a.topRows(2).cwiseMin(1.0), 5);
        FAIL() << "no error";
    } catch (const dynval::invalid_parameter& err) {
        EXPECT_EQ(err.parameter(), "max_lag");
        EXPECT_EQ(err.requirement(), "an integer with 0 <= max_lag < 2");
    }
}

}  // namespace
