// Streaming, mergeable autocorrelation (contract §3.4) and portmanteau tests (§3.5) of a residual
// that is read in blocks of rows, never held whole, or split across processes whose partial
// results are merged afterwards.
//
// A thin layer over stream_state (stream_state.hpp) with the layout {m, p = 0, max_lag, 0, no
// gram}: the lag sums, the merge and the segment breaks are the state's (its target sums are fed
// the residual and not read). This header adds what the state leaves to its caller:
// * the finiteness check: the first non-finite entry (row-major, global row index over every row
//   added or merged) is recorded and result() reports it as NonFiniteInput;
// * the size and max_lag checks of the in-memory functions, with their messages;
// * the centring on the overall mean: with d = Σ(e − K)/N (overall mean minus the state's centre),
//   Σ(e_t − ē)(e_{t−ℓ} − ē) = P_ℓ − d·(H_ℓ + T_ℓ) + n_ℓ·d².
#pragma once

#include "checked.hpp"
#include "correlation.hpp"
#include "errors.hpp"
#include "finite.hpp"
#include "options.hpp"
#include "stream_state.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace dynval {

/// Mergeable per-joint lag sums for ℓ = 0..max_lag over rows of a residual (N, m).
///
/// `update(rows)` adds rows that follow the ones seen so far (any Eigen expression, any number
/// of rows, also fewer than max_lag); `break_segment()` starts a new segment; `merge(later)`
/// appends the rows of another accumulator (with the same m and max_lag) as if they had been
/// added here. `result(adjusted)` is `dynval::autocorrelation` of all rows with the same
/// segments.
class lag_accumulator {
public:
    lag_accumulator(Index n_joints, Index max_lag) : state_(checked_layout(n_joints, max_lag)) {}

    Index n_joints() const noexcept { return state_.layout().m; }
    Index max_lag() const noexcept { return state_.layout().acf_lags; }
    Index n_samples() const noexcept { return static_cast<Index>(state_.n); }
    /// Length of the longest segment so far (the contract's limit for max_lag and lags).
    Index longest_segment() const noexcept {
        return state_.lengths.empty() ? 0 : static_cast<Index>(*std::max_element(state_.lengths.begin(), state_.lengths.end()));
    }
    /// n_ℓ, ℓ = 0..max_lag: the number of lag-ℓ products (n_0 = N).
    std::vector<Index> lag_products() const { return {state_.pairs.begin(), state_.pairs.end()}; }
    /// First non-finite entry seen, row-major, with its global row index.
    const std::optional<nonfinite_entry>& nonfinite() const noexcept { return nonfinite_; }
    /// The underlying stream state.
    const stream_state& state() const noexcept { return state_; }

    /// Adds rows that follow the rows seen so far, in the current segment.
    template <class D>
    lag_accumulator& update(const Eigen::MatrixBase<D>& rows) {
        const Index before = n_samples();
        state_.append(rows, rows);  // checks the shape first
        if (!nonfinite_)
            if ((nonfinite_ = first_nonfinite(rows))) nonfinite_->row += before;
        return *this;
    }

    /// Ends the current segment: no lagged product joins rows before and after this call.
    /// Calling it before any row keeps a later merge from joining this range to the previous one.
    lag_accumulator& break_segment() {
        state_.break_segment();
        return *this;
    }

    /// Appends `later`, whose rows follow this accumulator's rows (in the same segment unless
    /// a break lies between them).
    lag_accumulator& merge(const lag_accumulator& later) {
        std::optional<nonfinite_entry> hit = later.nonfinite_;  // a copy: `later` may be *this
        const Index before = n_samples();
        state_.merge(later.state_);
        if (!nonfinite_ && hit) {
            hit->row += before;
            nonfinite_ = hit;
        }
        return *this;
    }

    /// Σ_{products}(x_k − x̄)(x_{k−ℓ} − x̄), ℓ = 0..max_lag, one column per joint (the biased
    /// autocovariance times N). No checks; see result(). `scaled`: in the units 4^k of the state's
    /// exponent k per joint (stream_state.hpp), as the ratios of result() and the portmanteau
    /// tests take them (no square underflows there); otherwise in the data's units (IEEE).
    Eigen::MatrixXd lag_sums(bool scaled = false) const {
        const Index m = n_joints();
        const double nd = static_cast<double>(state_.n);
        Eigen::MatrixXd sums(max_lag() + 1, m);
        for (Index l = 0; l <= max_lag(); ++l)
            for (Index j = 0; j < m; ++j) {
                const auto i = static_cast<std::size_t>(l * m + j);
                const double d = state_.cur_e.value(static_cast<std::size_t>(j)) / nd;
                const double sum = state_.prod_e.value(i) - d * (state_.cur_e.value(i) + state_.lag_e.value(i)) +
                                   static_cast<double>(state_.pairs[static_cast<std::size_t>(l)]) * d * d;
                sums(l, j) = scaled ? sum : std::ldexp(sum, static_cast<int>(2 * state_.exp_e[static_cast<std::size_t>(j)]));
            }
        return sums;
    }

    /// ρ̂(ℓ), ℓ = 0..max_lag, per joint: (max_lag+1, m), equal to `dynval::autocorrelation` of
    /// all rows with the same segments. `adjusted=false` gives the biased autocorrelation that
    /// the portmanteau tests use. Throws TooFewSamples (N < 2), NonFiniteInput (the first
    /// non-finite entry) or InvalidParameter (max_lag not below the longest segment), in that
    /// order. A constant joint gives nan.
    row_matrix result(bool adjusted = true) const {
        check("autocorrelation", max_lag() + 1);
        const Eigen::MatrixXd sums = lag_sums(true);
        const std::vector<bool> constant = constant_joints();
        const double nd = static_cast<double>(state_.n);
        row_matrix rho(max_lag() + 1, n_joints());
        for (Index j = 0; j < n_joints(); ++j) {
            const double r0 = sums(0, j) / nd;
            for (Index l = 0; l <= max_lag(); ++l) {
                const double d = adjusted && l > 0 ? static_cast<double>(state_.pairs[static_cast<std::size_t>(l)]) : nd;
                rho(l, j) = constant[static_cast<std::size_t>(j)] ? std::numeric_limits<double>::quiet_NaN()
                                                                  : (sums(l, j) / d) / r0;
            }
        }
        return rho;
    }

    /// Per joint: true where the joint is constant over every row seen (autocorrelation nan).
    std::vector<bool> constant_joints() const {
        std::vector<bool> c(static_cast<std::size_t>(n_joints()));
        for (std::size_t j = 0; j < c.size(); ++j) c[j] = state_.min_e[j] == state_.max_e[j];
        return c;
    }

    /// The size, finiteness and max_lag checks of result(), with `function` in the messages and
    /// `lag_limit` the largest lag + 1 that the caller needs.
    void check(const std::string& function, Index lag_limit) const {
        detail::check_min_samples(n_samples(), 2, function);
        if (nonfinite_) detail::throw_nonfinite("e", nonfinite_->row, nonfinite_->col, nonfinite_->value);
        if (lag_limit - 1 >= longest_segment())
            detail::throw_parameter("max_lag", "an integer with 0 <= max_lag < " + std::to_string(longest_segment()),
                                    value_text(static_cast<long long>(lag_limit - 1)));
    }

private:
    /// The state's layout, after the checks of the contract (§5.2): m >= 1 and max_lag >= 0;
    /// `stream_state` refuses (max_lag + 1)·m cells that do not fit in memory.
    static stream_layout checked_layout(Index n_joints, Index max_lag) {
        if (n_joints < 1) throw invalid_shape("e must have at least one column, got " + std::to_string(n_joints));
        if (max_lag < 0)
            detail::throw_parameter("max_lag", "an integer with max_lag >= 0", value_text(static_cast<long long>(max_lag)));
        return stream_layout{n_joints, 0, max_lag, 0, false};
    }

    stream_state state_;
    std::optional<nonfinite_entry> nonfinite_;
};

/// Ljung–Box or Box–Pierce statistics (contract §3.5) of the rows in `acc`, at lags
/// 1 <= h <= acc.max_lag().
inline PortmanteauTest portmanteau(const lag_accumulator& acc, const std::vector<long long>& lags, long long model_df,
                                   portmanteau_test test) {
    const std::string function =
        option_traits<portmanteau_test>::valid(test) ? option_name(test) : std::string("portmanteau");
    acc.check(function, 1);
    const Index limit = std::min(acc.longest_segment(), acc.max_lag() + 1);
    const auto checked = detail::check_portmanteau_parameters(lags, model_df, test, limit);
    const Eigen::MatrixXd sums = acc.lag_sums(true);
    return detail::portmanteau_from_sums(sums.topRows(checked.max_lag + 1), acc.lag_products(),
                                         static_cast<double>(acc.n_samples()), acc.constant_joints(), lags,
                                         checked.model_df, checked.test);
}

/// Ljung–Box Q(h) = N(N+2) Σ ρ̂²_ℓ / n_ℓ of the rows in `acc`.
inline PortmanteauTest ljung_box(const lag_accumulator& acc, const std::vector<long long>& lags,
                                 long long model_df = 0) {
    return portmanteau(acc, lags, model_df, portmanteau_test::ljung_box);
}

/// Box–Pierce Q(h) = N Σ ρ̂²_ℓ of the rows in `acc`.
inline PortmanteauTest box_pierce(const lag_accumulator& acc, const std::vector<long long>& lags,
                                  long long model_df = 0) {
    return portmanteau(acc, lags, model_df, portmanteau_test::box_pierce);
}

}  // namespace dynval
