// Streaming, mergeable lag sums: the autocorrelation (contract §3.4) and the portmanteau tests
// (§3.5) of a residual that is read in blocks of rows, never held whole, or split across
// processes whose partial results are merged afterwards.
//
// Lagged products need the overall mean before the products, which a single pass does not
// have. The accumulator therefore keeps, per joint, sums about a fixed shift c (the first row
// seen; y = x − c):
//   P_ℓ = Σ_{products} y_k y_{k−ℓ},   S = Σ y,
//   H_ℓ = Σ_segments (sum of the segment's first min(ℓ, n_s) values of y),
//   T_ℓ = Σ_segments (sum of its last min(ℓ, n_s) values),
//   n_ℓ = Σ_segments max(n_s − ℓ, 0),
// and centres at the end: with d = S/N (the overall mean minus c),
//   Σ(x_k − x̄)(x_{k−ℓ} − x̄) = P_ℓ − d·(2S − H_ℓ − T_ℓ) + n_ℓ·d²
// (S − H_ℓ sums the later member of each product, S − T_ℓ the earlier one). The identity is
// exact; the centring cancels only the part of P_ℓ that comes from (x̄ − c)², so an offset
// shared by every row (1e7 on a signal of unit spread) costs nothing. What it does cost is a
// first row far out in the tails: the lag sums then lose about log10(1 + ((x̄ − c)/σ)²) digits.
//
// To merge with the range that follows, the accumulator also keeps the raw values of the first
// max_lag rows of its first segment and the last max_lag rows of its last one: the products
// that cross the junction are formed exactly from them, and the head/tail sums of the joined
// segment are corrected. The later range's sums are moved to this one's shift
// (y' = y + (c_later − c)) with the same identity. Counts add; first-order sums are carried in
// Neumaier-compensated form (the Chan et al. pairwise scheme with sums kept about a shift).
// A segment break (break_segment) closes the current segment: no product crosses it; means
// stay overall, as the contract requires.
//
// Finiteness is checked in the same pass: the first non-finite entry (row-major, global row
// index over every row added or merged) is recorded and result() reports it as NonFiniteInput.
#pragma once

#include "accumulator.hpp"
#include "correlation.hpp"
#include "errors.hpp"
#include "options.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
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
    /// Rows gathered per internal step (kept with the max_lag carried rows in cache).
    static constexpr Index block_rows = 256;

    lag_accumulator(Index n_joints, Index max_lag) : m_(n_joints), L_(max_lag) {
        if (n_joints < 1) throw invalid_shape("e must have at least one column, got " + std::to_string(n_joints));
        if (max_lag < 0)
            detail::throw_parameter("max_lag", "an integer with max_lag >= 0", value_text(static_cast<long long>(max_lag)));
        // (max_lag + 1)·m cells per sum: a count that wraps would allocate a short buffer.
        const auto lags = detail::checked_add(L_, 1);
        const auto cell_count = lags ? detail::checked_mul(*lags, m_) : std::nullopt;
        if (!cell_count || *cell_count > static_cast<long long>(std::vector<double>().max_size()))
            throw std::length_error("lag_accumulator: (max_lag + 1) * n_joints cells do not fit in memory");
        const auto cells = static_cast<std::size_t>(*cell_count);
        s_.assign(static_cast<std::size_t>(m_), {});
        p_.assign(cells, {});
        h_.assign(cells, {});
        t_.assign(cells, {});
        nprod_.assign(static_cast<std::size_t>(L_ + 1), 0);
        shift_ = Eigen::ArrayXd::Zero(m_);
        min_ = Eigen::ArrayXd::Constant(m_, std::numeric_limits<double>::infinity());
        max_ = Eigen::ArrayXd::Constant(m_, -std::numeric_limits<double>::infinity());
        head_.resize(L_, m_);
        tail_.resize(L_, m_);
        raw_.resize(L_ + block_rows, m_);
        work_.resize(L_ + block_rows, m_);
    }

    Index n_joints() const noexcept { return m_; }
    Index max_lag() const noexcept { return L_; }
    Index n_samples() const noexcept { return n_; }
    /// Length of the longest segment so far (the contract's limit for max_lag and lags).
    Index longest_segment() const noexcept { return longest_; }
    /// n_ℓ, ℓ = 0..max_lag: the number of lag-ℓ products (n_0 = N).
    const std::vector<Index>& lag_products() const noexcept { return nprod_; }
    /// First non-finite entry seen, row-major, with its global row index.
    const std::optional<nonfinite_entry>& nonfinite() const noexcept { return nonfinite_; }

    /// Adds rows that follow the rows seen so far, in the current segment.
    template <class D>
    lag_accumulator& update(const Eigen::MatrixBase<D>& rows) {
        eigen_assert(rows.cols() == m_);
        for (Index start = 0; start < rows.rows(); start += block_rows)
            add_block(rows, start, std::min(block_rows, rows.rows() - start));
        return *this;
    }

    /// Ends the current segment: no lagged product joins rows before and after this call.
    /// Calling it before any row keeps a later merge from joining this range to the previous one.
    lag_accumulator& break_segment() {
        if (cur_len_ > 0) {
            std::vector<detail::compensated> one(static_cast<std::size_t>(L_ + 1));
            for (Index j = 0; j < m_; ++j) {
                const Eigen::VectorXd y = tail_.col(j).head(tail_n_).array() - shift_(j);
                std::fill(one.begin(), one.end(), detail::compensated{});
                add_tail_sums_into(one, y, cur_len_);
                for (Index l = 1; l <= L_; ++l) t_[idx(l, j)].add(one[static_cast<std::size_t>(l)]);
            }
            cur_len_ = 0;
            tail_n_ = 0;
        }
        if (n_ == 0) start_open_ = false;
        return *this;
    }

    /// Appends `later`, whose rows follow this accumulator's rows (in the same segment unless
    /// a break lies between them).
    lag_accumulator& merge(const lag_accumulator& later) {
        eigen_assert(later.m_ == m_ && later.L_ == L_);
        if (&later == this) {  // the rows twice: merge a copy, the loops below read `later`
            const lag_accumulator copy = later;
            return merge(copy);
        }
        if (later.n_ == 0) {
            if (!later.start_open_) break_segment();
            return *this;
        }
        if (n_ == 0) {
            const bool open = start_open_ && later.start_open_;
            *this = later;
            start_open_ = open;
            return *this;
        }
        if (!nonfinite_ && later.nonfinite_) {
            nonfinite_ = later.nonfinite_;
            nonfinite_->row += n_;
        }
        const bool joined = cur_len_ > 0 && later.start_open_;
        const Index a = cur_len_;             // rows of this range's last segment (0: closed)
        const Index b = later.first_len_;     // rows of later's first segment
        const Index ta = tail_n_;             // = min(L, a)
        const Index hb = later.head_n_;       // = min(L, b)
        const bool later_single_open = later.n_seg_ == 1 && later.cur_len_ > 0;
        const double nb = static_cast<double>(later.n_);

        for (Index j = 0; j < m_; ++j) {
            const double c = shift_(j), cb = later.shift_(j);
            const double delta = cb - c;
            // later's boundary rows, and this range's last rows, about this shift.
            const Eigen::VectorXd yb = later.head_.col(j).head(hb).array() - c;
            const Eigen::VectorXd ya = tail_.col(j).head(ta).array() - c;
            // The tail sums of later's open segment (not yet in its T), about later's shift.
            std::vector<detail::compensated> later_t(static_cast<std::size_t>(L_ + 1));
            for (Index l = 0; l <= L_; ++l) later_t[static_cast<std::size_t>(l)] = later.t_[idx(l, j)];
            if (later.cur_len_ > 0) {
                const Eigen::VectorXd y_open = later.tail_.col(j).head(later.tail_n_).array() - cb;
                add_tail_sums_into(later_t, y_open, later.cur_len_);
            }
            for (Index l = 0; l <= L_; ++l) {
                const auto k = idx(l, j);
                const auto ul = static_cast<std::size_t>(l);
                const double n_l = static_cast<double>(later.nprod_[ul]);
                const double heads = static_cast<double>(later.n_ - later.nprod_[ul]);  // rows in H_ℓ
                // P' = P + δ·(members after + members before) + n_ℓ δ², about this shift.
                detail::compensated members;
                members.add(later.s_[static_cast<std::size_t>(j)]);
                members.add(later.s_[static_cast<std::size_t>(j)]);
                members.add(negated(later.h_[k]));
                members.add(negated(later_t[ul]));
                add_product(p_[k], delta, members.value());
                add_product(p_[k], n_l * delta, delta);
                p_[k].add(later.p_[k]);
                // H' = H + (rows in heads)·δ; T (closed segments only) likewise.
                h_[k].add(later.h_[k]);
                detail::add_scaled_difference(h_[k], heads, cb, c);
                const Index open_rows = later.cur_len_ > 0 ? std::min(l, later.cur_len_) : 0;
                t_[k].add(later.t_[k]);
                detail::add_scaled_difference(t_[k], heads - static_cast<double>(open_rows), cb, c);
                if (joined) {
                    // Products with the later member in later's first segment (position i < ℓ)
                    // and the earlier one in this range's last segment (position a + i − ℓ).
                    const Index i0 = std::max<Index>(0, l - ta), i1 = std::min(l, hb);
                    if (i1 > i0) {
                        p_[k].add(yb.segment(i0, i1 - i0).dot(ya.segment(ta - l + i0, i1 - i0)));
                    }
                    // Head of the joined segment: later's first segment is no longer a head of
                    // its own; its rows are a head only where they fall within ℓ of the joined
                    // segment's start.
                    const Index keep = std::min(std::max<Index>(l - a, 0), b);
                    if (i1 > keep) h_[k].add(-yb.segment(keep, i1 - keep).sum());
                    // Tail of the joined segment, when later closed it: this range's last rows
                    // within ℓ of its end.
                    if (!later_single_open && l > b) {
                        const Index r = std::min(l - b, a);
                        t_[k].add(ya.tail(r).sum());
                    }
                } else if (cur_len_ > 0) {
                    // This range's last segment is closed by the junction: its tail sums join T.
                    const Index r = std::min(l, a);
                    t_[k].add(ya.tail(r).sum());
                }
            }
            detail::compensated& s = s_[static_cast<std::size_t>(j)];
            s.add(later.s_[static_cast<std::size_t>(j)]);
            detail::add_scaled_difference(s, nb, cb, c);
        }
        for (Index l = 0; l <= L_; ++l) {
            const auto ul = static_cast<std::size_t>(l);
            nprod_[ul] += later.nprod_[ul];
            if (joined) nprod_[ul] += std::max<Index>(0, std::min(l, hb) - std::max<Index>(0, l - ta));
        }
        min_ = min_.min(later.min_);
        max_ = max_.max(later.max_);

        // Boundary rows of the merged range.
        if (joined && n_seg_ == 1) {  // this range was one open segment: it grows into later's
            const Index add = std::min(L_ - head_n_, hb);
            head_.middleRows(head_n_, add) = later.head_.topRows(add);
            head_n_ += add;
            first_len_ += b;
        }
        if (joined) longest_ = std::max(longest_, a + b);
        longest_ = std::max(longest_, later.longest_);
        if (joined && later_single_open) {
            const Index total = std::min(L_, a + later.cur_len_);
            const Index from_this = total - later.tail_n_;
            Eigen::MatrixXd merged(total, m_);
            merged.topRows(from_this) = tail_.middleRows(ta - from_this, from_this);
            merged.bottomRows(later.tail_n_) = later.tail_.topRows(later.tail_n_);
            tail_.topRows(total) = merged;
            tail_n_ = total;
            cur_len_ = a + later.cur_len_;
        } else {
            tail_.topRows(later.tail_n_) = later.tail_.topRows(later.tail_n_);
            tail_n_ = later.tail_n_;
            cur_len_ = later.cur_len_;
        }
        n_seg_ += later.n_seg_ - (joined ? 1 : 0);
        n_ += later.n_;
        return *this;
    }

    /// Σ_{products}(x_k − x̄)(x_{k−ℓ} − x̄), ℓ = 0..max_lag, one column per joint (the biased
    /// autocovariance times N). No checks; see result().
    Eigen::MatrixXd lag_sums() const {
        Eigen::MatrixXd sums(L_ + 1, m_);
        const double nd = static_cast<double>(n_);
        std::vector<detail::compensated> tails(static_cast<std::size_t>(L_ + 1));
        for (Index j = 0; j < m_; ++j) {
            const detail::compensated& s = s_[static_cast<std::size_t>(j)];
            const double d = s.value() / nd;
            for (Index l = 0; l <= L_; ++l) tails[static_cast<std::size_t>(l)] = t_[idx(l, j)];
            if (cur_len_ > 0) {
                const Eigen::VectorXd y_open = tail_.col(j).head(tail_n_).array() - shift_(j);
                add_tail_sums_into(tails, y_open, cur_len_);
            }
            for (Index l = 0; l <= L_; ++l) {
                detail::compensated members;  // 2S − H_ℓ − T_ℓ
                members.add(s);
                members.add(s);
                members.add(negated(h_[idx(l, j)]));
                members.add(negated(tails[static_cast<std::size_t>(l)]));
                detail::compensated c = p_[idx(l, j)];
                add_product(c, -d, members.value());
                add_product(c, static_cast<double>(nprod_[static_cast<std::size_t>(l)]) * d, d);
                sums(l, j) = c.value();
            }
        }
        return sums;
    }

    /// ρ̂(ℓ), ℓ = 0..max_lag, per joint: (max_lag+1, m), equal to `dynval::autocorrelation` of
    /// all rows with the same segments. `adjusted=false` gives the biased autocorrelation that
    /// the portmanteau tests use. Throws TooFewSamples (N < 2), NonFiniteInput (the first
    /// non-finite entry) or InvalidParameter (max_lag not below the longest segment), in that
    /// order. A constant joint gives nan.
    row_matrix result(bool adjusted = true) const {
        check("autocorrelation", L_ + 1);
        const Eigen::MatrixXd sums = lag_sums();
        const double nd = static_cast<double>(n_);
        row_matrix rho(L_ + 1, m_);
        for (Index j = 0; j < m_; ++j) {
            const bool constant = min_(j) == max_(j);
            const double r0 = sums(0, j) / nd;
            for (Index l = 0; l <= L_; ++l) {
                const double d = adjusted && l > 0 ? static_cast<double>(nprod_[static_cast<std::size_t>(l)]) : nd;
                rho(l, j) = constant ? std::numeric_limits<double>::quiet_NaN() : (sums(l, j) / d) / r0;
            }
        }
        return rho;
    }

    /// Per joint: true where the joint is constant over every row seen (autocorrelation nan).
    std::vector<bool> constant_joints() const {
        std::vector<bool> c(static_cast<std::size_t>(m_));
        for (Index j = 0; j < m_; ++j) c[static_cast<std::size_t>(j)] = min_(j) == max_(j);
        return c;
    }

    /// The size, finiteness and max_lag checks of result(), with `function` in the messages and
    /// `lag_limit` the largest lag + 1 that the caller needs.
    void check(const std::string& function, Index lag_limit) const {
        detail::check_min_samples(n_, 2, function);
        if (nonfinite_) detail::throw_nonfinite("e", nonfinite_->row, nonfinite_->col, nonfinite_->value);
        if (lag_limit - 1 >= longest_)
            detail::throw_parameter("max_lag", "an integer with 0 <= max_lag < " + std::to_string(longest_),
                                    value_text(static_cast<long long>(lag_limit - 1)));
    }

private:
    std::size_t idx(Index lag, Index j) const { return static_cast<std::size_t>(lag * m_ + j); }

    static detail::compensated negated(const detail::compensated& c) { return {-c.sum, -c.carry}; }

    /// acc += a·b with the product's rounding error carried too.
    static void add_product(detail::compensated& acc, double a, double b) {
        const double p = a * b;
        acc.add(p);
        acc.add(std::fma(a, b, -p));
    }

    /// sums[ℓ] += Σ of the last min(ℓ, len) values of y (y holds the last min(L, len) values of
    /// a segment of `len` rows), ℓ = 1..L.
    void add_tail_sums_into(std::vector<detail::compensated>& sums, const Eigen::VectorXd& y, Index len) const {
        const Index n = y.size();
        double run = 0.0;
        for (Index l = 1; l <= L_; ++l) {
            if (l <= std::min(len, n)) run += y(n - l);
            sums[static_cast<std::size_t>(l)].add(run);
        }
    }

    template <class D>
    void add_block(const Eigen::MatrixBase<D>& rows, Index start, Index nb) {
        const Index t = tail_n_;  // carried rows of the current segment (min(L, its length))
        raw_.topRows(t) = tail_.topRows(t);
        for (Index i = 0; i < nb; ++i)
            for (Index j = 0; j < m_; ++j) raw_(t + i, j) = rows.coeff(start + i, j);
        if (n_ == 0) {
            for (Index j = 0; j < m_; ++j) shift_(j) = std::isfinite(raw_(0, j)) ? raw_(0, j) : 0.0;
        }
        if (cur_len_ == 0) ++n_seg_;  // the first row of a new segment
        const Index used = t + nb;
        work_.topRows(used) = raw_.topRows(used).rowwise() - shift_.transpose().matrix();
        const Index p0 = cur_len_;  // position of the block's first row in its segment
        const Index head_rows = std::max<Index>(0, std::min(nb, L_ - p0));
        bool finite = true;
        for (Index j = 0; j < m_; ++j) {
            const auto y = work_.col(j).head(used);
            const double block_sum = y.tail(nb).sum();
            if (!std::isfinite(block_sum)) finite = false;
            s_[static_cast<std::size_t>(j)].add(block_sum);
            for (Index l = 0; l <= L_; ++l) {
                const Index lo = std::max(t, t - p0 + l);  // later member at segment position >= ℓ
                if (lo >= used) break;
                p_[idx(l, j)].add(y.segment(lo, used - lo).dot(y.segment(lo - l, used - lo)));
            }
            // Rows at segment position p < L belong to the head of every lag ℓ > p.
            double run = 0.0;
            for (Index l = p0 + 1; l <= L_; ++l) {
                if (l - p0 <= head_rows) run += y(t + (l - p0) - 1);
                h_[idx(l, j)].add(run);
            }
            const auto x = raw_.col(j).segment(t, nb).array();
            const double lo = x.minCoeff(), hi = x.maxCoeff();
            min_(j) = std::min(min_(j), lo);
            max_(j) = std::max(max_(j), hi);
            if (!(-lo <= detail::max_magnitude && hi <= detail::max_magnitude)) finite = false;  // out of range
        }
        for (Index l = 0; l <= L_; ++l)
            nprod_[static_cast<std::size_t>(l)] += std::max<Index>(0, p0 + nb - std::max(p0, l));
        if (!finite && !nonfinite_) {
            if (auto hit = detail::scan_nonfinite(rows, start, nb)) {
                hit->row += n_ - start;
                nonfinite_ = hit;
            }
        }
        if (n_seg_ == 1 && head_rows > 0) {
            head_.middleRows(head_n_, head_rows) = raw_.middleRows(t, head_rows);
            head_n_ += head_rows;
        }
        const Index keep = std::min(L_, used);
        tail_.topRows(keep) = raw_.middleRows(used - keep, keep);
        tail_n_ = keep;
        cur_len_ += nb;
        if (n_seg_ == 1) first_len_ = cur_len_;
        longest_ = std::max(longest_, cur_len_);
        n_ += nb;
    }

    Index m_, L_;
    Index n_ = 0;
    Index n_seg_ = 0;       // segments holding at least one row
    Index first_len_ = 0;   // rows of the first segment
    Index cur_len_ = 0;     // rows of the last segment while it is open; 0 once closed
    Index longest_ = 0;
    Index head_n_ = 0, tail_n_ = 0;  // = min(L, first_len_), min(L, cur_len_)
    bool start_open_ = true;         // a merge may join this range to the one before it
    Eigen::ArrayXd shift_;
    std::vector<detail::compensated> s_;        // Σ y per joint
    std::vector<detail::compensated> p_, h_, t_;  // (L+1)·m: P_ℓ, H_ℓ, T_ℓ (closed segments)
    std::vector<Index> nprod_;
    Eigen::ArrayXd min_, max_;
    Eigen::MatrixXd head_, tail_;  // raw first rows of the first segment, last rows of the open one
    Eigen::MatrixXd raw_, work_;   // carried rows + one block, raw and shifted
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
    const Eigen::MatrixXd sums = acc.lag_sums();
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
