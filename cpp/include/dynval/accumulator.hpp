// One-pass, mergeable per-joint accumulator over rows of (tau_meas, tau_pred).
//
// Every point metric, the residual mean/variance and the information criteria come from the
// moments gathered here in a single pass over the data, including the finiteness check (the
// first non-finite entry of each array is recorded, in row-major order, during the same pass).
//
// Accuracy: rows are processed in small blocks whose moments are combined with Chan et al.'s
// pairwise update into Neumaier-compensated running sums kept about a per-joint shift (the first
// rows' values), so a large common offset costs no digits. Inside a block:
// * generic path (any Eigen expression: strided Map, block, column-major): the block is
//   gathered into a cache-resident buffer and its mean and centred sums are computed two-pass;
// * contiguous row-major path (C-ordered numpy arrays, the binding's case): one vectorised pass
//   of deviations from the previous block's mean, M2 = S2 − S1²/n per block. Its rounding error
//   is eps·n·(block mean − shift)², bounded by the block-to-block drift, which for blocks of
//   256 samples is small against the total spread of a torque signal.
// Both paths agree with the numpy reference (correctly rounded sums, corrected two-pass means)
// to a few 1e-16 of the natural scale on well-conditioned data (tests/test_backends_agree.py
// holds them to 1e-14). They may differ more when a joint's spread is below ~1e-9 of its offset
// (every implementation then loses the digits that the input representation does not hold) and,
// for the `full` noise model, in proportion to the condition number of the residual covariance.
//
// Lagged products (autocorrelation, cross-correlation) need the overall mean before the
// products, so they are computed by correlation.hpp in a second pass over the residual; see
// that header for the streaming plan.
#pragma once

#include "compensated.hpp"
#include "errors.hpp"
#include "finite.hpp"
#include "simd.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

namespace dynval {

/// Moments of one or more blocks of rows, per joint (column).
struct joint_moments {
    Index n_samples = 0;
    Index n_joints = 0;
    Eigen::ArrayXd tau_mean, tau_m2;  ///< mean and centred sum of squares of tau_meas
    Eigen::ArrayXd e_mean, e_m2;      ///< the same for e = tau_meas - tau_pred
    Eigen::ArrayXd tau_shift, tau_dev, e_shift, e_dev;  ///< mean = shift + dev, dev small
    Eigen::ArrayXd sse;               ///< Σ e²
    Eigen::ArrayXd max_abs_e;
    Eigen::ArrayXd tau_min, tau_max, e_min, e_max;  ///< for the contract's constancy tests
    Eigen::MatrixXd residual_gram;    ///< EᵀE (m×m, not demeaned); empty unless requested
    std::optional<nonfinite_entry> nonfinite_meas, nonfinite_pred;
    /// Power-of-two scales (contract §1.3): the tau_* fields describe tau·2^-tau_exp(j), the
    /// e_*, sse and max_abs_e fields e·2^-e_exp(j), the gram e·2^-gram_exp. All 0 unless
    /// `rescale_tiny` found a sum of squares below the normal range (data near 1e-160).
    Eigen::ArrayXi tau_exp, e_exp;
    int gram_exp = 0;

    /// A sum of squares in scaled units: its value is `sum`·4^exp.
    struct scaled_sum {
        double sum = 0.0;
        int exp = 0;
        double value() const { return std::ldexp(sum, 2 * exp); }
    };
    /// a/b for two scaled sums, exact in the exponents.
    static double ratio(const scaled_sum& a, const scaled_sum& b) {
        return std::ldexp(a.sum / b.sum, 2 * (a.exp - b.exp));
    }
    scaled_sum sse_of(Index j) const { return {sse(j), e_exp(j)}; }
    scaled_sum e_m2_of(Index j) const { return {e_m2(j), e_exp(j)}; }
    scaled_sum tau_m2_of(Index j) const { return {tau_m2(j), tau_exp(j)}; }
    /// Per-joint values in the data's units (a value below the float64 range underflows).
    Eigen::ArrayXd sse_values() const { return unscale(sse, e_exp, 2); }
    Eigen::ArrayXd e_m2_values() const { return unscale(e_m2, e_exp, 2); }
    Eigen::ArrayXd tau_m2_values() const { return unscale(tau_m2, tau_exp, 2); }
    Eigen::ArrayXd e_mean_values() const { return unscale(e_mean, e_exp, 1); }
    Eigen::ArrayXd tau_mean_values() const { return unscale(tau_mean, tau_exp, 1); }
    Eigen::ArrayXd max_abs_e_values() const { return unscale(max_abs_e, e_exp, 1); }
    /// √(SSE_j/N) per joint, scaled back after the root (so it does not underflow).
    Eigen::ArrayXd rmse_values() const {
        Eigen::ArrayXd r(n_joints);
        for (Index j = 0; j < n_joints; ++j)
            r(j) = std::ldexp(std::sqrt(sse(j) / static_cast<double>(n_samples)), e_exp(j));
        return r;
    }

    /// Throws NonFiniteInput for the first non-finite entry, tau_meas before tau_pred.
    void throw_if_nonfinite(const std::string& meas_name = "tau_meas",
                            const std::string& pred_name = "tau_pred") const {
        if (nonfinite_meas)
            detail::throw_nonfinite(meas_name, nonfinite_meas->row, nonfinite_meas->col, nonfinite_meas->value);
        if (nonfinite_pred)
            detail::throw_nonfinite(pred_name, nonfinite_pred->row, nonfinite_pred->col, nonfinite_pred->value);
    }

    /// Σ_j SSE_j in the data's units, and as a scaled sum (exponent of the largest joint).
    double sse_total() const { return sse_pooled().value(); }
    scaled_sum sse_pooled() const;
    /// Mean of all N·m values of tau_meas and the centred sum of squares about it (pooled TSS).
    scaled_sum pooled_tau_m2() const {
        if (tau_min.minCoeff() == tau_max.maxCoeff()) return {};
        return pooled_m2(tau_shift, tau_dev, tau_m2, tau_exp, tau_min, tau_max);
    }
    scaled_sum pooled_e_m2() const {
        if (e_min.minCoeff() == e_max.maxCoeff()) return {};
        return pooled_m2(e_shift, e_dev, e_m2, e_exp, e_min, e_max);
    }
    /// The largest exponent among joints that are not all zero: the pooled sums' common scale.
    static int common_exp(const Eigen::ArrayXi& exps, const Eigen::ArrayXd& lo, const Eigen::ArrayXd& hi) {
        int k = std::numeric_limits<int>::min();
        for (Index j = 0; j < exps.size(); ++j)
            if (lo(j) != 0.0 || hi(j) != 0.0) k = std::max(k, exps(j));
        return k == std::numeric_limits<int>::min() ? 0 : k;
    }

private:
    static Eigen::ArrayXd unscale(const Eigen::ArrayXd& v, const Eigen::ArrayXi& exps, int power) {
        Eigen::ArrayXd r(v.size());
        for (Index j = 0; j < v.size(); ++j) r(j) = std::ldexp(v(j), power * exps(j));
        return r;
    }
    scaled_sum pooled_m2(const Eigen::ArrayXd& shift, const Eigen::ArrayXd& dev, const Eigen::ArrayXd& m2,
                         const Eigen::ArrayXi& exps, const Eigen::ArrayXd& lo, const Eigen::ArrayXd& hi) const;
};

/// Per-joint accumulator: `update(rows)`, `merge(later rows)`, `result()`.
///
/// `merge(other)` combines as if `other`'s rows followed this accumulator's rows (row indices
/// of a non-finite entry found by `other` are shifted accordingly).
namespace detail {

/// The per-lane arrays of joint_accumulator's fused block kernel, carved from one buffer of
/// `arrays` × lanes doubles: sums of target and residual deviations and their squares, the sum
/// of squared residuals, extremes, and the shifts the deviations are taken from.
struct lane_sums {
    static constexpr Index arrays = 11;
    double *s1t, *s2t, *s1e, *s2e, *sq, *min_t, *max_t, *min_e, *max_e, *shift_t, *shift_e;

    static lane_sums over(double* buffer, Index lanes) {
        lane_sums ls{};
        double** fields[arrays] = {&ls.s1t,   &ls.s2t,   &ls.s1e,   &ls.s2e,     &ls.sq,     &ls.min_t,
                                   &ls.max_t, &ls.min_e, &ls.max_e, &ls.shift_t, &ls.shift_e};
        for (Index i = 0; i < arrays; ++i) *fields[i] = buffer + i * lanes;
        return ls;
    }
};

}  // namespace detail

class joint_accumulator {
public:
    /// Rows per internal block; small enough that a block of both inputs stays in L1/L2.
    static constexpr Index block_rows = 128;

    explicit joint_accumulator(Index n_joints, bool residual_gram = false)
        : m_(n_joints), with_gram_(residual_gram) {
        tau_sum_.assign(static_cast<std::size_t>(m_), {});
        e_sum_.assign(static_cast<std::size_t>(m_), {});
        tau_m2_.assign(static_cast<std::size_t>(m_), {});
        e_m2_.assign(static_cast<std::size_t>(m_), {});
        sse_.assign(static_cast<std::size_t>(m_), {});
        const double inf = std::numeric_limits<double>::infinity();
        max_abs_e_ = Eigen::ArrayXd::Zero(m_);
        tau_min_ = Eigen::ArrayXd::Constant(m_, inf);
        tau_max_ = Eigen::ArrayXd::Constant(m_, -inf);
        e_min_ = Eigen::ArrayXd::Constant(m_, inf);
        e_max_ = Eigen::ArrayXd::Constant(m_, -inf);
        if (with_gram_) gram_ = Eigen::MatrixXd::Zero(m_, m_);
        tau_buf_.resize(block_rows, m_);
        tau_shift_ = Eigen::ArrayXd::Zero(m_);
        e_shift_ = Eigen::ArrayXd::Zero(m_);
        next_shift_t_ = Eigen::ArrayXd::Zero(m_);
        next_shift_e_ = Eigen::ArrayXd::Zero(m_);
        e_buf_.resize(block_rows, m_);
    }

    Index n_samples() const noexcept { return n_; }
    Index n_joints() const noexcept { return m_; }

    /// Adds a block of rows (any Eigen expression: Map with strides, Ref, block, ...).
    template <class A, class B>
    joint_accumulator& update(const Eigen::MatrixBase<A>& tau_meas, const Eigen::MatrixBase<B>& tau_pred) {
        eigen_assert(tau_meas.cols() == m_ && tau_pred.cols() == m_ && tau_meas.rows() == tau_pred.rows());
        const Index rows = tau_meas.rows();
        if constexpr (row_major_direct<A>() && row_major_direct<B>()) {
            // C-contiguous (N, m) data, the binding's common case: a vectorised one-pass kernel.
            if (contiguous_rows(tau_meas) && contiguous_rows(tau_pred)) {
                add_contiguous(tau_meas.derived().data(), tau_pred.derived().data(), rows);
                return *this;
            }
        }
        for (Index start = 0; start < rows; start += block_rows) {
            const Index nb = std::min(block_rows, rows - start);
            add_block(tau_meas, tau_pred, start, nb);
        }
        return *this;
    }

    /// Adds rows of one signal (tau_pred taken as 0): moments of a residual or a regressor.
    template <class A>
    joint_accumulator& update_signal(const Eigen::MatrixBase<A>& x) {
        eigen_assert(x.cols() == m_);
        if constexpr (row_major_direct<A>()) {
            if (contiguous_rows(x)) {
                add_contiguous(x.derived().data(), nullptr, x.rows());
                return *this;
            }
        }
        return update(x, A::PlainObject::Zero(x.rows(), x.cols()));
    }

    /// Combines with an accumulator holding the rows that follow this one's.
    joint_accumulator& merge(const joint_accumulator& later) {
        eigen_assert(later.m_ == m_);
        if (!nonfinite_meas_ && later.nonfinite_meas_) {
            nonfinite_meas_ = later.nonfinite_meas_;
            nonfinite_meas_->row += n_;
        }
        if (!nonfinite_pred_ && later.nonfinite_pred_) {
            nonfinite_pred_ = later.nonfinite_pred_;
            nonfinite_pred_->row += n_;
        }
        if (n_ == 0) {
            tau_shift_ = later.tau_shift_;
            e_shift_ = later.e_shift_;
        }
        const double nl = static_cast<double>(later.n_);
        for (Index j = 0; j < m_; ++j) {
            const auto k = static_cast<std::size_t>(j);
            // later's sums are about its own shift; move them to ours (M2 does not depend on it).
            detail::compensated ts = later.tau_sum_[k], es = later.e_sum_[k];
            detail::add_scaled_difference(ts, nl, later.tau_shift_(j), tau_shift_(j));
            detail::add_scaled_difference(es, nl, later.e_shift_(j), e_shift_(j));
            combine(tau_sum_[k], tau_m2_[k], n_, ts, later.tau_m2_[k], later.n_);
            combine(e_sum_[k], e_m2_[k], n_, es, later.e_m2_[k], later.n_);
            sse_[k].add(later.sse_[k]);
        }
        max_abs_e_ = max_abs_e_.max(later.max_abs_e_);
        tau_min_ = tau_min_.min(later.tau_min_);
        tau_max_ = tau_max_.max(later.tau_max_);
        e_min_ = e_min_.min(later.e_min_);
        e_max_ = e_max_.max(later.e_max_);
        if (with_gram_ && later.with_gram_) gram_ += later.gram_;
        n_ += later.n_;
        next_shift_valid_ = false;
        return *this;
    }

    /// The moments so far.
    joint_moments result() const {
        joint_moments r;
        r.n_samples = n_;
        r.n_joints = m_;
        r.tau_mean.resize(m_);
        r.tau_m2.resize(m_);
        r.e_mean.resize(m_);
        r.e_m2.resize(m_);
        r.sse.resize(m_);
        r.tau_shift = tau_shift_;
        r.e_shift = e_shift_;
        r.tau_dev.resize(m_);
        r.e_dev.resize(m_);
        const double n = static_cast<double>(n_);
        for (Index j = 0; j < m_; ++j) {
            const auto k = static_cast<std::size_t>(j);
            r.tau_dev(j) = n_ ? tau_sum_[k].value() / n : std::numeric_limits<double>::quiet_NaN();
            r.e_dev(j) = n_ ? e_sum_[k].value() / n : std::numeric_limits<double>::quiet_NaN();
            r.tau_mean(j) = n_ ? detail::shifted_mean(tau_shift_(j), tau_sum_[k], n) : r.tau_dev(j);
            r.e_mean(j) = n_ ? detail::shifted_mean(e_shift_(j), e_sum_[k], n) : r.e_dev(j);
            // A constant column has exactly zero spread, whatever the rounding of its mean.
            r.tau_m2(j) = tau_min_(j) == tau_max_(j) ? 0.0 : tau_m2_[k].value();
            r.e_m2(j) = e_min_(j) == e_max_(j) ? 0.0 : e_m2_[k].value();
            r.sse(j) = sse_[k].value();
        }
        r.max_abs_e = max_abs_e_;
        r.tau_min = tau_min_;
        r.tau_max = tau_max_;
        r.e_min = e_min_;
        r.e_max = e_max_;
        if (with_gram_) r.residual_gram = gram_.selfadjointView<Eigen::Lower>();
        r.nonfinite_meas = nonfinite_meas_;
        r.nonfinite_pred = nonfinite_pred_;
        r.tau_exp = Eigen::ArrayXi::Zero(m_);
        r.e_exp = Eigen::ArrayXi::Zero(m_);
        return r;
    }

private:
    /// max(|tau|, |e|) of a block is at most max_magnitude / 2 (false with NaN or ±inf).
    static bool block_in_half_range(double tau_lo, double tau_hi, double e_lo, double e_hi) noexcept {
        constexpr double half = 0.5 * detail::max_magnitude;
        return -tau_lo <= half && tau_hi <= half && -e_lo <= half && e_hi <= half;
    }

    template <class D>
    static constexpr bool row_major_direct() {
        return (int(D::Flags) & Eigen::DirectAccessBit) && (int(D::Flags) & Eigen::RowMajorBit);
    }
    template <class D>
    bool contiguous_rows(const Eigen::MatrixBase<D>& a) const {
        return a.derived().innerStride() == 1 && (a.rows() <= 1 || a.derived().outerStride() == m_);
    }

    /// One pass over C-contiguous rows. The block is read as a flat array with 2m independent
    /// lanes (lane l is joint l mod m), so every update is elementwise and vectorises without
    /// reassociating sums. Within a block (small enough to stay in cache) the block mean is
    /// found first and the sums are of deviations from it, so M2 = S2 − S1²/n of a block has
    /// two-pass accuracy; blocks are then combined with Chan's update like the generic path.
    void add_contiguous(const double* t, const double* p, Index rows) {
        const Index m = m_, lanes = 2 * m_;
        const double inf = std::numeric_limits<double>::infinity();
        lane_.resize(static_cast<std::size_t>(detail::lane_sums::arrays * lanes));
        const detail::lane_sums ls = detail::lane_sums::over(lane_.data(), lanes);
        double *s1t = ls.s1t, *s2t = ls.s2t, *s1e = ls.s1e, *s2e = ls.s2e, *sq = ls.sq;
        double *mnt = ls.min_t, *mxt = ls.max_t, *mne = ls.min_e, *mxe = ls.max_e, *kt = ls.shift_t, *ke = ls.shift_e;
        constexpr Index fast_rows = 256;
        for (Index start = 0; start < rows; start += fast_rows) {
            const Index nb = std::min(fast_rows, rows - start);
            const double* tb = t + start * m;
            if (!p && zeros_.size() < static_cast<std::size_t>(fast_rows * m)) zeros_.assign(static_cast<std::size_t>(fast_rows * m), 0.0);
            const double* pb = p ? p + start * m : zeros_.data();
            if (n_ == 0) {
                for (Index j = 0; j < m; ++j) {
                    tau_shift_(j) = std::isfinite(tb[j]) ? tb[j] : 0.0;
                    const double e0 = tb[j] - pb[j];
                    e_shift_(j) = std::isfinite(e0) ? e0 : 0.0;
                }
            }
            // Sums are of deviations from a shift close to the block mean, so M2 = S2 − S1²/n
            // of a block keeps two-pass accuracy: the previous block's mean (blocks are short
            // against the drift of a torque signal), or for the first block its own mean.
            const Index pairs = nb / 2;
            if (n_ > 0 && !next_shift_valid_) {  // after a merge or a generic-path block
                for (Index j = 0; j < m; ++j) {
                    const auto k = static_cast<std::size_t>(j);
                    next_shift_t_(j) = tau_shift_(j) + tau_sum_[k].value() / static_cast<double>(n_);
                    next_shift_e_(j) = e_shift_(j) + e_sum_[k].value() / static_cast<double>(n_);
                }
            }
            if (n_ == 0) {
                for (Index j = 0; j < m; ++j) next_shift_t_(j) = next_shift_e_(j) = 0.0;
                for (Index r = 0; r < nb; ++r)
                    for (Index j = 0; j < m; ++j) {
                        next_shift_t_(j) += tb[r * m + j];
                        next_shift_e_(j) += tb[r * m + j] - pb[r * m + j];
                    }
                next_shift_t_ /= static_cast<double>(nb);
                next_shift_e_ /= static_cast<double>(nb);
            }
            for (Index j = 0; j < m; ++j) {
                kt[j] = kt[j + m] = std::isfinite(next_shift_t_(j)) ? next_shift_t_(j) : 0.0;
                ke[j] = ke[j + m] = std::isfinite(next_shift_e_(j)) ? next_shift_e_(j) : 0.0;
            }
            for (Index l = 0; l < lanes; ++l) {
                s1t[l] = s2t[l] = s1e[l] = s2e[l] = sq[l] = 0.0;
                mnt[l] = mne[l] = inf;
                mxt[l] = mxe[l] = -inf;
            }
            if (p) {
                lane_kernel(tb, pb, pairs, lanes, ls);
                if (nb % 2)  // the last row of an odd block: one row of lanes 0..m-1
                    lane_kernel(tb + pairs * lanes, pb + pairs * lanes, 1, m, ls);
            } else {
                signal_lane_kernel(tb, pairs, lanes, ls);
                if (nb % 2) signal_lane_kernel(tb + pairs * lanes, 1, m, ls);
            }
            const double nbd = static_cast<double>(nb);
            bool finite = true;
            for (Index j = 0; j < m; ++j) {
                const auto k = static_cast<std::size_t>(j);
                const Index h = j + m;
                const double a1 = s1t[j] + s1t[h], a2 = s2t[j] + s2t[h];
                const double b1 = s1e[j] + s1e[h], b2 = s2e[j] + s2e[h];
                if (!std::isfinite(a1) || !std::isfinite(b1) || !std::isfinite(a2) || !std::isfinite(b2))
                    finite = false;
                // Out-of-range inputs: |tau| > L or |pred| > L implies max(|tau|, |e|) > L/2, so this
                // cheap test on the block's extremes sends every such block to the exact scan.
                if (!block_in_half_range(mnt[j], mxt[j], mne[j], mxe[j]) ||
                    (pairs > 0 && !block_in_half_range(mnt[h], mxt[h], mne[h], mxe[h])))
                    finite = false;
                // NaN compares false, so min/max above skip it; the finiteness scan catches it.
                tau_min_(j) = std::min({tau_min_(j), mnt[j], mnt[h]});
                tau_max_(j) = std::max({tau_max_(j), mxt[j], mxt[h]});
                e_min_(j) = std::min({e_min_(j), mne[j], mne[h]});
                e_max_(j) = std::max({e_max_(j), mxe[j], mxe[h]});
                max_abs_e_(j) = std::max({max_abs_e_(j), -e_min_(j), e_max_(j)});
                sse_[k].add(sq[j] + sq[h]);
                detail::compensated bs_t, bs_e;
                bs_t.add(a1);
                detail::add_scaled_difference(bs_t, nbd, kt[j], tau_shift_(j));
                bs_e.add(b1);
                detail::add_scaled_difference(bs_e, nbd, ke[j], e_shift_(j));
                next_shift_t_(j) = kt[j] + a1 / nbd;
                next_shift_e_(j) = ke[j] + b1 / nbd;
                const detail::compensated bm2_t{std::max(a2 - a1 * a1 / nbd, 0.0), 0.0};
                const detail::compensated bm2_e{std::max(b2 - b1 * b1 / nbd, 0.0), 0.0};
                combine(tau_sum_[k], tau_m2_[k], n_, bs_t, bm2_t, nb);
                combine(e_sum_[k], e_m2_[k], n_, bs_e, bm2_e, nb);
            }
            if (with_gram_) {
                using RowMap = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;
                e_buf_.topRows(std::min(nb, block_rows)).setZero();
                for (Index s = 0; s < nb; s += block_rows) {
                    const Index q = std::min(block_rows, nb - s);
                    e_buf_.topRows(q) = RowMap(tb + s * m, q, m) - RowMap(pb + s * m, q, m);
                    gram_.selfadjointView<Eigen::Lower>().rankUpdate(e_buf_.topRows(q).transpose());
                }
            }
            if (!finite) {
                const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> tm(tb, nb, m),
                    pm(pb, nb, m);
                if (!nonfinite_meas_) {
                    if (auto hit = detail::scan_nonfinite(tm, 0, nb)) {
                        hit->row += n_;
                        nonfinite_meas_ = hit;
                    }
                }
                if (!nonfinite_pred_) {
                    if (auto hit = detail::scan_nonfinite(pm, 0, nb)) {
                        hit->row += n_;
                        nonfinite_pred_ = hit;
                    }
                }
            }
            n_ += nb;
            next_shift_valid_ = true;
        }
    }

    static void lane_kernel(const double* tb, const double* pb, Index pairs, Index lanes,
                            const detail::lane_sums& ls) {
        lane_kernel(tb, pb, pairs, lanes, ls.s1t, ls.s2t, ls.s1e, ls.s2e, ls.sq, ls.min_t, ls.max_t, ls.min_e,
                    ls.max_e, ls.shift_t, ls.shift_e);
    }

    // The lanes never alias each other or the data: `restrict` parameters let the loop
    // vectorise (GCC does not take the promise from struct members or restrict locals: 2.5x
    // slower). On x86-64 with GCC an AVX2 clone is picked at load time where the CPU has it.
    DYNVAL_VECTOR_CLONES static void lane_kernel(const double* DYNVAL_RESTRICT tb, const double* DYNVAL_RESTRICT pb,
                                                 Index pairs, Index lanes, double* DYNVAL_RESTRICT s1t,
                                                 double* DYNVAL_RESTRICT s2t, double* DYNVAL_RESTRICT s1e,
                                                 double* DYNVAL_RESTRICT s2e, double* DYNVAL_RESTRICT sq,
                                                 double* DYNVAL_RESTRICT mnt, double* DYNVAL_RESTRICT mxt,
                                                 double* DYNVAL_RESTRICT mne, double* DYNVAL_RESTRICT mxe,
                                                 const double* DYNVAL_RESTRICT kt, const double* DYNVAL_RESTRICT ke) {
        for (Index c = 0; c < pairs; ++c) {
            const double* tc = tb + c * lanes;
            const double* pc = pb + c * lanes;
            for (Index l = 0; l < lanes; ++l) {
                const double x = tc[l], e = x - pc[l];
                const double dt = x - kt[l], de = e - ke[l];
                s1t[l] += dt;
                s2t[l] += dt * dt;
                s1e[l] += de;
                s2e[l] += de * de;
                sq[l] += e * e;
                mnt[l] = x < mnt[l] ? x : mnt[l];
                mxt[l] = x > mxt[l] ? x : mxt[l];
                mne[l] = e < mne[l] ? e : mne[l];
                mxe[l] = e > mxe[l] ? e : mxe[l];
            }
        }
    }

    /// lane_kernel of one signal (the prediction 0): e = x − 0 is x exactly and its shift is x's
    /// (the same values from the first block on), so the residual's lanes are copies of the signal's,
    /// bit for bit, and the pass keeps 5 lane arrays instead of 9 (a 490-column regressor's 980
    /// lanes of 9 arrays overflow the L1 cache).
    static void signal_lane_kernel(const double* tb, Index pairs, Index lanes, const detail::lane_sums& ls) {
        signal_lanes(tb, pairs, lanes, ls.s1t, ls.s2t, ls.sq, ls.min_t, ls.max_t, ls.shift_t);
        std::copy(ls.s1t, ls.s1t + lanes, ls.s1e);
        std::copy(ls.s2t, ls.s2t + lanes, ls.s2e);
        std::copy(ls.min_t, ls.min_t + lanes, ls.min_e);
        std::copy(ls.max_t, ls.max_t + lanes, ls.max_e);
    }

    DYNVAL_VECTOR_CLONES static void signal_lanes(const double* DYNVAL_RESTRICT tb, Index pairs, Index lanes,
                                                  double* DYNVAL_RESTRICT s1t, double* DYNVAL_RESTRICT s2t,
                                                  double* DYNVAL_RESTRICT sq, double* DYNVAL_RESTRICT mnt,
                                                  double* DYNVAL_RESTRICT mxt, const double* DYNVAL_RESTRICT kt) {
        for (Index c = 0; c < pairs; ++c) {
            const double* tc = tb + c * lanes;
            for (Index l = 0; l < lanes; ++l) {
                const double x = tc[l], dt = x - kt[l];
                s1t[l] += dt;
                s2t[l] += dt * dt;
                sq[l] += x * x;
                mnt[l] = x < mnt[l] ? x : mnt[l];
                mxt[l] = x > mxt[l] ? x : mxt[l];
            }
        }
    }

    // Chan et al.: combine (sum_a, M2_a, n_a) with (sum_b, M2_b, n_b).
    static void combine(detail::compensated& sum_a, detail::compensated& m2_a, Index n_a,
                        const detail::compensated& sum_b, const detail::compensated& m2_b, Index n_b) {
        if (n_b == 0) return;
        if (n_a > 0) {
            const double na = static_cast<double>(n_a), nb = static_cast<double>(n_b);
            const double delta = sum_b.value() / nb - sum_a.value() / na;
            m2_a.add(delta * delta * (na * nb / (na + nb)));
        }
        m2_a.add(m2_b);
        sum_a.add(sum_b);
    }

    template <class A, class B>
    void add_block(const Eigen::MatrixBase<A>& meas, const Eigen::MatrixBase<B>& pred, Index start, Index nb) {
        // Gather the block column-major so the per-joint passes below are contiguous.
        for (Index i = 0; i < nb; ++i)
            for (Index j = 0; j < m_; ++j) {
                const double t = meas.coeff(start + i, j);
                tau_buf_(i, j) = t;
                e_buf_(i, j) = t - pred.coeff(start + i, j);
            }
        auto tau = tau_buf_.topRows(nb);
        auto e = e_buf_.topRows(nb);
        if (with_gram_) gram_.selfadjointView<Eigen::Lower>().rankUpdate(e.transpose());
        const double nbd = static_cast<double>(nb);
        if (n_ == 0) {
            // Sums are kept about a per-joint shift (the first block's mean), so block means are
            // small and their differences in Chan's update do not lose the digits of an offset.
            for (Index j = 0; j < m_; ++j) {
                tau_shift_(j) = tau.col(j).sum() / nbd;
                e_shift_(j) = e.col(j).sum() / nbd;
                if (!std::isfinite(tau_shift_(j))) tau_shift_(j) = 0.0;
                if (!std::isfinite(e_shift_(j))) e_shift_(j) = 0.0;
            }
        }
        bool finite = true;
        for (Index j = 0; j < m_; ++j) {
            const auto k = static_cast<std::size_t>(j);
            auto tj = tau.col(j).array();
            auto ej = e.col(j).array();
            // Extremes and Σe² on the data as given (exact constancy tests, unshifted SSE).
            sse_[k].add(ej.square().sum());
            max_abs_e_(j) = std::max(max_abs_e_(j), ej.abs().maxCoeff());
            const double tlo = tj.minCoeff(), thi = tj.maxCoeff(), elo = ej.minCoeff(), ehi = ej.maxCoeff();
            tau_min_(j) = std::min(tau_min_(j), tlo);
            tau_max_(j) = std::max(tau_max_(j), thi);
            e_min_(j) = std::min(e_min_(j), elo);
            e_max_(j) = std::max(e_max_(j), ehi);
            if (!block_in_half_range(tlo, thi, elo, ehi)) finite = false;  // see add_contiguous
            tj -= tau_shift_(j);
            ej -= e_shift_(j);
            const double st = tj.sum();
            const double se = ej.sum();
            // NaN or ±inf in tau_meas makes st non-finite; in tau_pred (with finite tau) makes se.
            if (!std::isfinite(st) || !std::isfinite(se)) finite = false;
            const double mt = st / nbd, me = se / nbd;
            detail::compensated bs_t{st, 0.0}, bm2_t{(tj - mt).square().sum(), 0.0};
            detail::compensated bs_e{se, 0.0}, bm2_e{(ej - me).square().sum(), 0.0};
            combine(tau_sum_[k], tau_m2_[k], n_, bs_t, bm2_t, nb);
            combine(e_sum_[k], e_m2_[k], n_, bs_e, bm2_e, nb);
        }
        if (!finite) {
            if (!nonfinite_meas_) {
                if (auto hit = detail::scan_nonfinite(meas, start, nb)) {
                    hit->row += n_ - start;
                    nonfinite_meas_ = hit;
                }
            }
            if (!nonfinite_pred_) {
                if (auto hit = detail::scan_nonfinite(pred, start, nb)) {
                    hit->row += n_ - start;
                    nonfinite_pred_ = hit;
                }
            }
        }
        n_ += nb;
        next_shift_valid_ = false;
    }

    Index m_;
    bool with_gram_;
    Index n_ = 0;
    std::vector<detail::compensated> tau_sum_, e_sum_, tau_m2_, e_m2_, sse_;
    Eigen::ArrayXd max_abs_e_, tau_min_, tau_max_, e_min_, e_max_;
    Eigen::MatrixXd gram_;
    Eigen::MatrixXd tau_buf_, e_buf_;
    Eigen::ArrayXd tau_shift_, e_shift_;
    std::optional<nonfinite_entry> nonfinite_meas_, nonfinite_pred_;
    std::vector<double> lane_, zeros_;
    Eigen::ArrayXd next_shift_t_, next_shift_e_;  // shifts of the next contiguous block
    bool next_shift_valid_ = false;
};

inline joint_moments::scaled_sum joint_moments::sse_pooled() const {
    // Joints are brought to the largest joint's scale: smaller ones lose only what is below
    // its sum's last digit.
    const Eigen::ArrayXd zero = Eigen::ArrayXd::Zero(n_joints);
    const int k = common_exp(e_exp, zero, max_abs_e);
    detail::compensated s;
    for (Index j = 0; j < n_joints; ++j) s.add(std::ldexp(sse(j), 2 * (e_exp(j) - k)));
    return {s.value(), k};
}

inline joint_moments::scaled_sum joint_moments::pooled_m2(const Eigen::ArrayXd& shift, const Eigen::ArrayXd& dev,
                                                          const Eigen::ArrayXd& m2, const Eigen::ArrayXi& exps,
                                                          const Eigen::ArrayXd& lo, const Eigen::ArrayXd& hi) const {
    // Every joint at the common scale first (exact: powers of two).
    const int k = common_exp(exps, lo, hi);
    Eigen::ArrayXd sh(n_joints), dv(n_joints), q(n_joints);
    for (Index j = 0; j < n_joints; ++j) {
        sh(j) = std::ldexp(shift(j), exps(j) - k);
        dv(j) = std::ldexp(dev(j), exps(j) - k);
        q(j) = std::ldexp(m2(j), 2 * (exps(j) - k));
    }
    // Exact decomposition: Σ_kj (x_kj − x̄)² = Σ_j [M2_j + N (x̄_j − x̄)²]. The joint means are
    // compared about the first joint's shift, so an offset common to all joints cancels exactly.
    const Eigen::ArrayXd a = (sh - sh(0)) + dv;
    detail::compensated grand;
    for (Index j = 0; j < n_joints; ++j) grand.add(a(j));
    const double overall = grand.value() / static_cast<double>(n_joints);
    detail::compensated total;
    const double n = static_cast<double>(n_samples);
    for (Index j = 0; j < n_joints; ++j) {
        const double d = a(j) - overall;
        total.add(q(j));
        total.add(n * d * d);
    }
    return {total.value(), k};
}

/// Moments of one signal (a residual or a regressor) in one pass; its stats are the `tau_*`
/// fields and a non-finite entry is reported in `nonfinite_meas`.
template <class A>
joint_moments accumulate_signal(const Eigen::MatrixBase<A>& x) {
    joint_accumulator acc(x.cols());
    acc.update_signal(x);
    return acc.result();
}

/// Accumulates (tau_meas, tau_pred) in one pass.
template <class A, class B>
joint_moments accumulate(const Eigen::MatrixBase<A>& tau_meas, const Eigen::MatrixBase<B>& tau_pred,
                         bool residual_gram = false) {
    joint_accumulator acc(tau_meas.cols(), residual_gram);
    acc.update(tau_meas, tau_pred);
    return acc.result();
}

namespace detail {

/// Below this, a sum of squares may hold terms that left float64's normal range (|x| < 2^-511
/// squares to a subnormal or to 0). Above it, the terms lost cost less than 2^-270 of the sum.
constexpr double tiny_sum_of_squares = 0x1p-800;

/// Exponent k with largest·2^-k in [0.5, 1) for a sum of squares that needs rescaling; else 0.
inline int scale_exponent(double sum_of_squares, double largest) {
    if (!(sum_of_squares < tiny_sum_of_squares) || !(largest > 0.0)) return 0;
    int k = 0;
    std::frexp(largest, &k);
    return k;
}

inline double largest_abs(double lo, double hi) { return std::max(std::fabs(lo), std::fabs(hi)); }

/// x·2^-k column by column (exact: powers of two, scaling up). Two factors, because 2^-k alone
/// overflows for subnormal data (k down to −1073).
template <class D>
Eigen::MatrixXd scaled_columns(const Eigen::MatrixBase<D>& x, const Eigen::ArrayXi& exps) {
    Eigen::Array<double, 1, Eigen::Dynamic> f1(exps.size()), f2(exps.size());
    for (Index j = 0; j < exps.size(); ++j) {
        f1(j) = std::ldexp(1.0, -exps(j) / 2);
        f2(j) = std::ldexp(1.0, -exps(j) - (-exps(j) / 2));
    }
    Eigen::MatrixXd out = x;
    out.array().rowwise() *= f1;
    out.array().rowwise() *= f2;
    return out;
}

}  // namespace detail

/// Moments whose sums of squares keep full precision on data of any magnitude (contract §1.3).
///
/// The fast pass is exact for every sum of squares at or above 2^-800; a joint whose sum of τ
/// (centred) or of e (raw or centred) falls below it — data near 1e-160, whose squares underflow —
/// is accumulated again with that quantity scaled by a power of two (exact), and the exponent is
/// recorded. Data that do not need it are read once, as before.
template <class A, class B>
joint_moments rescale_tiny(joint_moments mo, const Eigen::MatrixBase<A>& tau_meas,
                           const Eigen::MatrixBase<B>& tau_pred, bool residual_gram = false) {
    const Index m = mo.n_joints;
    Eigen::ArrayXi tk = Eigen::ArrayXi::Zero(m), ek = Eigen::ArrayXi::Zero(m);
    for (Index j = 0; j < m; ++j) {
        const bool tau_constant = mo.tau_min(j) == mo.tau_max(j);
        const bool e_constant = mo.e_min(j) == mo.e_max(j);
        if (!tau_constant) tk(j) = detail::scale_exponent(mo.tau_m2(j), detail::largest_abs(mo.tau_min(j), mo.tau_max(j)));
        const double e_sum = e_constant ? mo.sse(j) : std::min(mo.sse(j), mo.e_m2(j));
        ek(j) = detail::scale_exponent(e_sum, mo.max_abs_e(j));
    }
    // The full noise model's Σ̂ takes one scale for every joint, so its eigenvalue ratios stay.
    int gk = 0;
    if (residual_gram) gk = detail::scale_exponent(mo.sse_total(), mo.max_abs_e.maxCoeff());
    if ((tk == 0).all() && (ek == 0).all() && gk == 0) return mo;
    if (!(tk == 0).all()) {
        const joint_moments t = accumulate_signal(detail::scaled_columns(tau_meas, tk));
        mo.tau_mean = t.tau_mean;
        mo.tau_m2 = t.tau_m2;
        mo.tau_shift = t.tau_shift;
        mo.tau_dev = t.tau_dev;
        mo.tau_min = t.tau_min;
        mo.tau_max = t.tau_max;
        mo.tau_exp = tk;
    }
    if (!(ek == 0).all()) {
        const joint_moments e = accumulate_signal(detail::scaled_columns(tau_meas - tau_pred, ek));
        mo.e_mean = e.tau_mean;
        mo.e_m2 = e.tau_m2;
        mo.e_shift = e.tau_shift;
        mo.e_dev = e.tau_dev;
        mo.e_min = e.tau_min;
        mo.e_max = e.tau_max;
        mo.sse = e.sse;
        mo.max_abs_e = e.max_abs_e;
        mo.e_exp = ek;
    }
    if (gk != 0) {
        joint_accumulator g(m, true);
        g.update_signal(detail::scaled_columns(tau_meas - tau_pred, Eigen::ArrayXi::Constant(m, gk)));
        mo.residual_gram = g.result().residual_gram;
        mo.gram_exp = gk;
    }
    return mo;
}

/// Moments of one signal, rescaled where its sums of squares are tiny.
template <class D>
joint_moments rescale_tiny_signal(joint_moments mo, const Eigen::MatrixBase<D>& x) {
    return rescale_tiny(mo, x, D::PlainObject::Zero(x.rows(), x.cols()));
}

}  // namespace dynval
