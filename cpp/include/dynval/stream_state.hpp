// The mergeable state of a validation stream (contract §4.1): everything the streamed report
// needs, in a size independent of the number of rows. It is the C++ form of the Python
// reference `dynval.streaming._stream.State` and follows it step by step, so the two agree to rounding:
//
// * per joint, about a centre K that follows the running mean: Σ(τ − K_τ) and Σ(τ − K_τ)² of the
//   target; for the residual e at every lag ℓ = 0..L the lagged products
//   P_ℓ = Σ(e_t − K)(e_{t−ℓ} − K), the sums of the current and of the lagged elements of the
//   same pairs H_ℓ = Σ(e_t − K), T_ℓ = Σ(e_{t−ℓ} − K), and the pair count n_ℓ;
// * per regressor column (joint j, column c), for ℓ = 0..Lx: Σ(e_t − K_e)(Y_{t−ℓ} − K_Y), the
//   lagged sums Σ(Y_{t−ℓ} − K_Y) over the same pairs (lag 0: Σ(Y − K_Y)) and Σ(Y − K_Y)²;
// * minima and maxima; the m × m residual products for the `full` noise model;
// * the raw first L rows of the first segment and the last L (Lx for Y) rows of the last one;
// * the segment lengths and whether the state starts or ends with a break.
//
// A new centre K' = K + δ needs only these sums:
//   Σ(x_t − K')(y_{t−ℓ} − K'') = P_ℓ − δ_y H_ℓ − δ_x T_ℓ + n_ℓ δ_x δ_y.
// `merge` moves both operands to their combined mean (Chan's pairwise update, extended to lagged
// products), adds the sums and adds the products that cross the junction (current element among
// the later operand's first rows, lagged element among the earlier one's last rows). Running
// sums are Neumaier-compensated. Every sum stays centred, so a first row far in the tails costs
// nothing. The C++ `lag_accumulator` (lag_accumulator.hpp) is a thin layer over this state.
//
// Every sum is held in units of a power of two per column (contract §4.1): `exp_e`, `exp_t` (m)
// and `exp_y` (m·p) are the exponents k (std::frexp) of the largest |x| seen in each column, 0 for
// a column of zeros, and the centres and sums are those of x·2^-k, so no square or product
// underflows or overflows at any accepted magnitude. A block takes the exponents of its own rows;
// `merge` moves both operands to the larger exponent of each column first (a multiplication by a
// power of two: exact, but for parts below 2^-1022 of the largest, which are below the rounding
// of the sums they join). Boundary rows, minima and maxima stay raw.
//
// The state does not check finiteness (the Python facade checks each chunk first).
#pragma once

#include "accumulator.hpp"  // DYNVAL_VECTOR_CLONES, DYNVAL_RESTRICT
#include "checked.hpp"
#include "errors.hpp"
#include "parallel.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <initializer_list>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace dynval {

namespace detail {

/// Σ a[i]·b[i] over eight independent lanes (the loop vectorises; an AVX2 clone where available).
DYNVAL_VECTOR_CLONES inline double stream_dot(const double* DYNVAL_RESTRICT a, const double* DYNVAL_RESTRICT b,
                                              Index count) {
    double part[8] = {};
    const Index chunks = count / 8;
    for (Index c = 0; c < chunks; ++c)
        for (int l = 0; l < 8; ++l) part[l] += a[c * 8 + l] * b[c * 8 + l];
    double tail = 0.0;
    for (Index i = chunks * 8; i < count; ++i) tail += a[i] * b[i];
    return (((part[0] + part[4]) + (part[1] + part[5])) + ((part[2] + part[6]) + (part[3] + part[7]))) + tail;
}

/// The lagged products Σ_{t=l}^{c-1} x[t]·x[t−l] for the four lags l = l0..l0+3 at once: each
/// loaded x[t] feeds four products (one dot product per lag loads two values per product), eight
/// lanes per lag. `out` receives the four sums.
DYNVAL_VECTOR_CLONES inline void stream_lag_tile(const double* DYNVAL_RESTRICT x, Index c, Index l0, double* out) {
    const Index start = l0 + 3;  // every lag of the tile has its pair from here on
    Index t_end = start;         // the products before t_end are in the lanes
    double lanes[4] = {};
#if defined(DYNVAL_VECTOR_TYPES)
    vec4 acc[4][2] = {};
    for (; t_end + 8 <= c; t_end += 8) {
        vec4 x0, x1;
        load4(x0, x + t_end);
        load4(x1, x + t_end + 4);
        for (int k = 0; k < 4; ++k) {
            vec4 y0, y1;
            load4(y0, x + t_end - l0 - k);
            load4(y1, x + t_end - l0 - k + 4);
            acc[k][0] += x0 * y0;
            acc[k][1] += x1 * y1;
        }
    }
    for (int k = 0; k < 4; ++k) {
        const vec4 a = acc[k][0] + acc[k][1];
        lanes[k] = (a[0] + a[2]) + (a[1] + a[3]);
    }
#endif
    for (int k = 0; k < 4; ++k) {
        double sum = lanes[k];
        for (Index t = std::max(t_end, start); t < c; ++t) sum += x[t] * x[t - l0 - k];
        for (Index t = l0 + k; t < std::min(start, c); ++t) sum += x[t] * x[t - l0 - k];
        out[k] = sum;
    }
}

/// Joint-major copies of k rows of m values (row strides sa, sp): t[j·k + i] = a[i·sa + j] and
/// e[j·k + i] = a[i·sa + j] − p[i·sp + j].
inline void residual_joint_major(const double* DYNVAL_RESTRICT a, Index sa, const double* DYNVAL_RESTRICT p, Index sp,
                                 Index k, Index m, double* DYNVAL_RESTRICT e, double* DYNVAL_RESTRICT t) {
    for (Index j = 0; j < m; ++j) {
        double* tj = t + j * k;
        double* ej = e + j * k;
        for (Index i = 0; i < k; ++i) {
            const double x = a[i * sa + j];
            tj[i] = x;
            ej[i] = x - p[i * sp + j];
        }
    }
}

/// Σ a[i] over eight independent lanes.
DYNVAL_VECTOR_CLONES inline double stream_sum(const double* DYNVAL_RESTRICT a, Index count) {
    double part[8] = {};
    const Index chunks = count / 8;
    for (Index c = 0; c < chunks; ++c)
        for (int l = 0; l < 8; ++l) part[l] += a[c * 8 + l];
    double tail = 0.0;
    for (Index i = chunks * 8; i < count; ++i) tail += a[i];
    return (((part[0] + part[4]) + (part[1] + part[5])) + ((part[2] + part[6]) + (part[3] + part[7]))) + tail;
}

/// Minimum, maximum and sum of a run of values in one pass (eight lanes).
DYNVAL_VECTOR_CLONES inline void stream_extremes(const double* DYNVAL_RESTRICT a, Index count, double& lo,
                                                 double& hi, double& sum) {
    constexpr double inf = std::numeric_limits<double>::infinity();
    double mn[8], mx[8], s[8];
    Index done = 0;
#if defined(DYNVAL_VECTOR_TYPES)
    vec4 vmn[2] = {vec4{inf, inf, inf, inf}, vec4{inf, inf, inf, inf}}, vmx[2] = {-vmn[0], -vmn[0]}, vs[2] = {};
    for (; done + 8 <= count; done += 8)
        for (int h = 0; h < 2; ++h) {
            vec4 v;
            load4(v, a + done + 4 * h);
            vmn[h] = v < vmn[h] ? v : vmn[h];
            vmx[h] = v > vmx[h] ? v : vmx[h];
            vs[h] += v;
        }
    for (int l = 0; l < 8; ++l) {
        mn[l] = vmn[l / 4][l % 4];
        mx[l] = vmx[l / 4][l % 4];
        s[l] = vs[l / 4][l % 4];
    }
#else
    for (int l = 0; l < 8; ++l) {
        mn[l] = inf;
        mx[l] = -inf;
        s[l] = 0.0;
    }
#endif
    for (Index i = done; i < count; ++i) {
        mn[0] = a[i] < mn[0] ? a[i] : mn[0];
        mx[0] = a[i] > mx[0] ? a[i] : mx[0];
        s[0] += a[i];
    }
    lo = std::min({mn[0], mn[1], mn[2], mn[3], mn[4], mn[5], mn[6], mn[7]});
    hi = std::max({mx[0], mx[1], mx[2], mx[3], mx[4], mx[5], mx[6], mx[7]});
    sum = ((s[0] + s[4]) + (s[1] + s[5])) + ((s[2] + s[6]) + (s[3] + s[7]));
}

}  // namespace detail

/// What a stream state holds: m joints, p regressor columns per joint (0: none), the lags of the
/// residual's autocorrelation (`acf_lags`) and of the cross-correlation (`xcorr_lags` ≤ acf_lags),
/// and whether the m × m residual products are kept (`gram`, the `full` noise model).
struct stream_layout {
    Index m = 1;
    Index p = 0;
    Index acf_lags = 0;
    Index xcorr_lags = 0;
    bool gram = false;
};

/// An array sum carried as hi + lo (Kahan–Babuška/Neumaier): lo keeps what each addition rounded away.
struct compensated_array {
    std::vector<double> hi, lo;

    compensated_array() = default;
    explicit compensated_array(std::size_t size) : hi(size, 0.0), lo(size, 0.0) {}

    std::size_t size() const noexcept { return hi.size(); }
    void add(std::size_t i, double x) noexcept {
        const double s = hi[i] + x;
        const double b = s - hi[i];
        lo[i] += (hi[i] - (s - b)) + (x - b);
        hi[i] = s;
    }
    void add_sum(const compensated_array& other) noexcept {
        for (std::size_t i = 0; i < hi.size(); ++i) {
            add(i, other.hi[i]);
            lo[i] += other.lo[i];
        }
    }
    double value(std::size_t i) const noexcept { return hi[i] + lo[i]; }
    /// Multiplies element i by 2^k (exact unless a part underflows).
    void scale(std::size_t i, int k) noexcept {
        hi[i] = std::ldexp(hi[i], k);
        lo[i] = std::ldexp(lo[i], k);
    }
    std::vector<double> values() const {
        std::vector<double> out(hi.size());
        for (std::size_t i = 0; i < hi.size(); ++i) out[i] = hi[i] + lo[i];
        return out;
    }
};

/// Centred, mergeable sums of a run of consecutive rows (one or more segments); see the top of
/// this file. Arrays are flat and row-major: lag-major `(L+1, m)` for the residual sums,
/// `(Lx+1, m, p)` for the regressor sums, `(m, p)` per column, `(m, m)` for the products.
class stream_state {
public:
    /// Every buffer's cell count, (acf_lags + 1)·m, m·p, (xcorr_lags + 1)·m·p and m·m, formed with
    /// overflow checks (a count that wraps would allocate a short buffer that the loops overrun),
    /// and the whole against the documented bound `max_cells`; std::length_error otherwise. The
    /// constructor calls it first; a caller may ask it before constructing.
    static void check_fits(const stream_layout& layout) {
        const long long limit = static_cast<long long>(std::vector<double>().max_size());
        const auto mp = detail::checked_mul(layout.m, layout.p);
        const auto le = detail::checked_add(layout.acf_lags, 1);
        const auto lx = detail::checked_add(layout.xcorr_lags, 1);
        const auto cells_e = le ? detail::checked_mul(*le, layout.m) : std::nullopt;
        const auto cells_y = (lx && mp) ? detail::checked_mul(*lx, *mp) : std::nullopt;
        const auto cells_g = layout.gram ? detail::checked_mul(layout.m, layout.m) : std::optional<long long>(0);
        const std::string text = "(m=" + std::to_string(layout.m) + ", p=" + std::to_string(layout.p) +
                                 ", acf_lags=" + std::to_string(layout.acf_lags) +
                                 ", xcorr_lags=" + std::to_string(layout.xcorr_lags) + ")";
        for (const auto& cells : {cells_e, cells_y, cells_g})
            if (!cells || *cells > limit)
                throw std::length_error("stream_state: the layout's buffers " + text + " do not fit in memory");
        // The documented bound (contract §4.1, the reference's state_cells):
        // 8(L+1)m + (L+1) + 5(Lx+1)mp + 2m² + 12m + 6mp, each term formed once the buffers it
        // sums are known to be at most max_cells (then nothing overflows; m, L+1 and mp are below them).
        const bool parts_fit = *cells_e <= max_cells && *cells_y <= max_cells && *cells_g <= max_cells;
        const long long total = parts_fit ? 8 * (*cells_e) + (*le) + 5 * (*cells_y) + 2 * (*cells_g) + 12 * layout.m +
                                                6 * (*mp)
                                          : max_cells + 1;
        if (total > max_cells)
            throw std::length_error("stream_state: the layout " + text + " would hold more than " +
                                    std::to_string(max_cells) + " numbers (1 GiB, contract §4.1)");
    }

    static constexpr double inf = std::numeric_limits<double>::infinity();
    /// Most numbers a state may hold (1 GiB of float64, contract §4.1): a larger layout is refused
    /// before anything is allocated (dynval.streaming._stream.MAX_STATE_CELLS).
    static constexpr long long max_cells = 1LL << 27;

    stream_state() : stream_state(stream_layout{}) {}
    explicit stream_state(const stream_layout& layout) : layout_(layout) {
        if (layout.m < 1) throw invalid_shape("stream_state needs at least one joint, got m=" + std::to_string(layout.m));
        if (layout.p < 0 || layout.acf_lags < 0 || layout.xcorr_lags < 0 || layout.xcorr_lags > layout.acf_lags)
            throw invalid_parameter("stream_state needs p >= 0 and 0 <= xcorr_lags <= acf_lags, got p=" +
                                    std::to_string(layout.p) + ", acf_lags=" + std::to_string(layout.acf_lags) +
                                    ", xcorr_lags=" + std::to_string(layout.xcorr_lags));
        check_fits(layout);
        const auto m = static_cast<std::size_t>(layout.m);
        const auto mp = m * static_cast<std::size_t>(layout.p);
        const auto le = static_cast<std::size_t>(layout.acf_lags) + 1;
        const auto lx = static_cast<std::size_t>(layout.xcorr_lags) + 1;
        exp_e.assign(m, 0);
        exp_t.assign(m, 0);
        exp_y.assign(mp, 0);
        k_e.assign(m, 0.0);
        prod_e = compensated_array(le * m);
        cur_e = compensated_array(le * m);
        lag_e = compensated_array(le * m);
        pairs.assign(le, 0);
        gram = compensated_array(layout.gram ? m * m : 0);
        min_e.assign(m, inf);
        max_e.assign(m, -inf);
        k_t.assign(m, 0.0);
        sum_t = compensated_array(m);
        sq_t = compensated_array(m);
        min_t.assign(m, inf);
        max_t.assign(m, -inf);
        k_y.assign(mp, 0.0);
        sq_y = compensated_array(mp);
        lag_y = compensated_array(lx * mp);
        prod_ey = compensated_array(lx * mp);
        min_y.assign(mp, inf);
        max_y.assign(mp, -inf);
    }

    const stream_layout& layout() const noexcept { return layout_; }
    /// Rows held per block summed at once: several times the lags, so the junction products of
    /// each merge cost little against the block's own products.
    Index block_rows() const noexcept { return std::max<Index>(2048, 4 * (layout_.acf_lags + 1)); }

    // ------------------------------------------------------------------ data (public: a plain record)
    long long n = 0;
    std::vector<long long> lengths;  // segment lengths, in order
    bool start_break = false;         // the first row must not join the rows before it
    bool end_break = false;           // the next row must not join the last row
    std::vector<long long> exp_e, exp_t, exp_y;  // power-of-two exponents per column: sums in their units
    std::vector<double> k_e;
    compensated_array prod_e, cur_e, lag_e;  // P_ℓ, H_ℓ (H_0 = Σ(e − K)), T_ℓ: (L+1, m)
    std::vector<long long> pairs;            // n_ℓ
    compensated_array gram;                  // (m, m) or empty
    std::vector<double> min_e, max_e;
    std::vector<double> k_t;
    compensated_array sum_t, sq_t;
    std::vector<double> min_t, max_t;
    std::vector<double> k_y;           // (m, p)
    compensated_array sq_y;            // (m, p)
    compensated_array lag_y, prod_ey;  // (Lx+1, m, p); lag_y at lag 0 is Σ(Y − K_Y)
    std::vector<double> min_y, max_y;
    std::vector<double> head_e, tail_e;  // raw rows (k, m): first rows of the first segment, last of the last
    std::vector<double> tail_y;          // raw rows (k, m·p)

    // ------------------------------------------------------------------ rows

    /// Adds rows that continue the current segment (they join the last rows unless `end_break`):
    /// residual `e` and target `tau` (c, m), regressor `y` (c, m·p) when p > 0. Summed in blocks of
    /// `block_rows()`, each block merged as the Python reference merges its blocks.
    template <class E, class T, class Y>
    void append(const Eigen::MatrixBase<E>& e, const Eigen::MatrixBase<T>& tau, const Eigen::MatrixBase<Y>& y) {
        check_rows(e.rows(), e.cols(), tau.rows(), tau.cols(), y.rows(), y.cols(), true);
        append_blocks(e.rows(), [&](Index a, Index k) {
            return from_block(layout_, e.middleRows(a, k), tau.middleRows(a, k), y.middleRows(a, k), true);
        });
    }
    /// `append` of measured and predicted rows (c, m): the residual e = meas − pred is formed block
    /// by block inside the state, so the caller holds no copy of the chunk (the Python facade's
    /// path). `y` as in `append`; `has_y` false when p = 0 (then `y` is not read).
    template <class A, class B, class Y>
    void append_measured(const Eigen::MatrixBase<A>& meas, const Eigen::MatrixBase<B>& pred,
                         const Eigen::MatrixBase<Y>& y, bool has_y) {
        const Index c = meas.rows();
        check_rows(c, meas.cols(), pred.rows(), pred.cols(), has_y ? y.rows() : c, has_y ? y.cols() : 0, has_y);
        const Index m = layout_.m, mp = has_y ? m * layout_.p : 0;
        append_blocks(c, [&](Index a, Index k) {
            // Joint-major copies: each lagged product is then a dot product of contiguous runs.
            JointRows xe(m, k), xt(m, k), xy(mp, k);
            constexpr bool rows_in_memory = (static_cast<int>(A::Flags) & Eigen::RowMajorBit) &&
                                            (static_cast<int>(A::Flags) & Eigen::DirectAccessBit) &&
                                            (static_cast<int>(B::Flags) & Eigen::RowMajorBit) &&
                                            (static_cast<int>(B::Flags) & Eigen::DirectAccessBit);
            bool copied = false;
            if constexpr (rows_in_memory) {
                if (meas.derived().innerStride() == 1 && pred.derived().innerStride() == 1) {
                    detail::residual_joint_major(meas.derived().data() + a * meas.derived().outerStride(),
                                                 meas.derived().outerStride(),
                                                 pred.derived().data() + a * pred.derived().outerStride(),
                                                 pred.derived().outerStride(), k, m, xe.data(), xt.data());
                    copied = true;
                }
            }
            if (!copied) {  // any other layout: Eigen's own transposed copies
                xt = meas.middleRows(a, k).transpose();
                xe = xt - pred.middleRows(a, k).transpose();
            }
            if (mp) xy = y.middleRows(a, k).transpose();
            return from_joint_major(layout_, xe, xt, xy);
        });
    }

    /// `append` without a regressor (p = 0).
    template <class E, class T>
    void append(const Eigen::MatrixBase<E>& e, const Eigen::MatrixBase<T>& tau) {
        check_rows(e.rows(), e.cols(), tau.rows(), tau.cols(), e.rows(), 0, false);
        append_blocks(e.rows(), [&](Index a, Index k) {
            return from_block(layout_, e.middleRows(a, k), tau.middleRows(a, k), e.middleRows(a, k), false);
        });
    }

    /// Ends the current segment: no lagged product joins the rows before and after.
    void break_segment() noexcept {
        if (n == 0)
            start_break = true;
        else
            end_break = true;
    }

    // ------------------------------------------------------------------ centres

    double mean_e(Index j) const { return k_e[j] + cur_e.value(static_cast<std::size_t>(j)) / static_cast<double>(n); }
    double mean_t(Index j) const { return k_t[j] + sum_t.value(static_cast<std::size_t>(j)) / static_cast<double>(n); }
    double mean_y(Index q) const { return k_y[q] + lag_y.value(static_cast<std::size_t>(q)) / static_cast<double>(n); }

    /// Moves every sum to new centres (x − K' = (x − K) − δ); each correction uses the sums as
    /// they were before any of them moves.
    void recentre(const std::vector<double>& ke, const std::vector<double>& kt, const std::vector<double>& ky) {
        const std::size_t m = static_cast<std::size_t>(layout_.m), mp = m * static_cast<std::size_t>(layout_.p);
        const std::size_t le = static_cast<std::size_t>(layout_.acf_lags), lx = static_cast<std::size_t>(layout_.xcorr_lags);
        const double nn = static_cast<double>(n);
        std::vector<double> d(m), cur = cur_e.values(), lag = lag_e.values();
        for (std::size_t j = 0; j < m; ++j) d[j] = ke[j] - k_e[j];
        if (layout_.gram) {
            for (std::size_t i = 0; i < m; ++i)
                for (std::size_t k = 0; k < m; ++k)
                    gram.add(i * m + k, -(d[i] * cur[k] + cur[i] * d[k]) + nn * (d[i] * d[k]));
        }
        if (mp) {
            std::vector<double> dy(mp), ly = lag_y.values();
            for (std::size_t q = 0; q < mp; ++q) dy[q] = ky[q] - k_y[q];
            const std::size_t p = static_cast<std::size_t>(layout_.p);
            for (std::size_t l = 0; l <= lx; ++l) {
                const double nl = static_cast<double>(pairs[l]);
                for (std::size_t j = 0; j < m; ++j)
                    for (std::size_t c = 0; c < p; ++c) {
                        const std::size_t q = j * p + c, i = l * mp + q;
                        prod_ey.add(i, -dy[q] * cur[l * m + j] - d[j] * ly[i] + nl * d[j] * dy[q]);
                    }
            }
            for (std::size_t q = 0; q < mp; ++q) sq_y.add(q, -2.0 * dy[q] * ly[q] + nn * dy[q] * dy[q]);
            for (std::size_t l = 0; l <= lx; ++l) {
                const double nl = static_cast<double>(pairs[l]);
                for (std::size_t q = 0; q < mp; ++q) lag_y.add(l * mp + q, -nl * dy[q]);
            }
            k_y = ky;
        }
        for (std::size_t l = 0; l <= le; ++l) {
            const double nl = static_cast<double>(pairs[l]);
            for (std::size_t j = 0; j < m; ++j) {
                const std::size_t i = l * m + j;
                prod_e.add(i, -d[j] * (cur[i] + lag[i]) + nl * d[j] * d[j]);
            }
        }
        for (std::size_t l = 0; l <= le; ++l) {
            const double nl = static_cast<double>(pairs[l]);
            for (std::size_t j = 0; j < m; ++j) {
                cur_e.add(l * m + j, -nl * d[j]);
                lag_e.add(l * m + j, -nl * d[j]);
            }
        }
        k_e = ke;
        const std::vector<double> st = sum_t.values();
        for (std::size_t j = 0; j < m; ++j) {
            const double dt = kt[j] - k_t[j];
            sq_t.add(j, -2.0 * dt * st[j] + nn * dt * dt);
            sum_t.add(j, -nn * dt);
        }
        k_t = kt;
    }

    /// Moves every centre and sum to the exponents given (each at least the state's own): a sum
    /// of products of columns a and b is multiplied by 2^-(da + db), a sum or centre by 2^-da.
    void rescale(const std::vector<long long>& ee, const std::vector<long long>& et, const std::vector<long long>& ey) {
        const std::size_t m = static_cast<std::size_t>(layout_.m), mp = m * static_cast<std::size_t>(layout_.p);
        const std::size_t le = static_cast<std::size_t>(layout_.acf_lags) + 1, lx = static_cast<std::size_t>(layout_.xcorr_lags) + 1;
        const std::size_t p = static_cast<std::size_t>(layout_.p);
        std::vector<int> de(m), dt(m), dy(mp);
        for (std::size_t j = 0; j < m; ++j) {
            de[j] = static_cast<int>(ee[j] - exp_e[j]);
            dt[j] = static_cast<int>(et[j] - exp_t[j]);
        }
        for (std::size_t q = 0; q < mp; ++q) dy[q] = static_cast<int>(ey[q] - exp_y[q]);
        for (std::size_t j = 0; j < m; ++j) {
            if (de[j]) {
                k_e[j] = std::ldexp(k_e[j], -de[j]);
                for (std::size_t l = 0; l < le; ++l) {
                    prod_e.scale(l * m + j, -2 * de[j]);
                    cur_e.scale(l * m + j, -de[j]);
                    lag_e.scale(l * m + j, -de[j]);
                }
                if (layout_.gram)
                    for (std::size_t k = 0; k < m; ++k) {
                        gram.scale(j * m + k, -de[j]);  // row j and column j: (j, j) twice
                        gram.scale(k * m + j, -de[j]);
                    }
            }
            if (dt[j]) {
                k_t[j] = std::ldexp(k_t[j], -dt[j]);
                sum_t.scale(j, -dt[j]);
                sq_t.scale(j, -2 * dt[j]);
            }
        }
        for (std::size_t q = 0; q < mp; ++q) {
            const int d = dy[q], dq = de[q / p] + dy[q];
            if (d) {
                k_y[q] = std::ldexp(k_y[q], -d);
                sq_y.scale(q, -2 * d);
            }
            for (std::size_t l = 0; l < lx; ++l) {
                if (d) lag_y.scale(l * mp + q, -d);
                if (dq) prod_ey.scale(l * mp + q, -dq);
            }
        }
        exp_e = ee;
        exp_t = et;
        exp_y = ey;
    }

    // ------------------------------------------------------------------ merge

    /// Adds `later` (rows that follow this state's rows in time). Lags join across the junction
    /// unless this state ends with a break or `later` starts with one.
    void merge(const stream_state& later) {
        check_same_layout(later);
        merge_owned(stream_state(later));
    }

    /// `merge` of a state this one may consume.
    void merge_owned(stream_state b) {
        check_same_layout(b);
        // Row counts from a pickle may be anything up to 2^63 − 1: their sum must not wrap.
        if (!detail::checked_add(n, b.n))
            throw invalid_parameter("stream_state.merge: the row counts " + std::to_string(n) + " and " +
                                    std::to_string(b.n) + " overflow 64 bits");
        if (b.n == 0) {
            end_break = end_break || b.start_break || b.end_break;
            return;
        }
        if (n == 0) {
            const bool pending = start_break || end_break;
            *this = std::move(b);
            start_break = start_break || pending;
            return;
        }
        const std::size_t m = static_cast<std::size_t>(layout_.m), mp = m * static_cast<std::size_t>(layout_.p);
        {  // both operands in the units of the larger exponent of each column
            auto larger = [](std::vector<long long> a, const std::vector<long long>& o) {
                for (std::size_t i = 0; i < a.size(); ++i) a[i] = std::max(a[i], o[i]);
                return a;
            };
            const auto ee = larger(exp_e, b.exp_e), et = larger(exp_t, b.exp_t), ey = larger(exp_y, b.exp_y);
            rescale(ee, et, ey);
            b.rescale(ee, et, ey);
        }
        const double w = static_cast<double>(b.n) / static_cast<double>(n + b.n);
        std::vector<double> ke(m), kt(m), ky(mp);
        for (std::size_t j = 0; j < m; ++j) {
            const double ma = mean_e(j), mb = b.mean_e(j), ta = mean_t(j), tb = b.mean_t(j);
            ke[j] = ma + w * (mb - ma);
            kt[j] = ta + w * (tb - ta);
        }
        for (std::size_t q = 0; q < mp; ++q) {
            const double ya = mean_y(q), yb = b.mean_y(q);
            ky[q] = ya + w * (yb - ya);
        }
        recentre(ke, kt, ky);
        b.recentre(ke, kt, ky);
        const bool join = !(end_break || b.start_break);
        if (join) add_junction(b);
        add_sums(b);
        join_boundaries(b, join);
    }

    /// The state of one segment of rows (the reference's `State.from_block`).
    template <class E, class T, class Y>
    static stream_state from_block(const stream_layout& layout, const Eigen::MatrixBase<E>& e,
                                   const Eigen::MatrixBase<T>& tau, const Eigen::MatrixBase<Y>& y, bool has_y) {
        JointRows xe = e.transpose(), xt = tau.transpose(), xy;
        if (has_y && layout.p) xy = y.transpose();
        return from_joint_major(layout, xe, xt, xy);
    }

private:
    using JointRows = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

    /// Merges block(a, k), the state of rows [a, a + k), for the blocks of `block_rows()` rows of
    /// c rows, in order. With enough work the blocks of a batch are formed on the machine's
    /// threads (each by one thread, as without threads) and then merged in order on this one, so
    /// the state is the same bit for bit whatever the thread count.
    template <class Block>
    void append_blocks(Index c, Block&& block) {
        const Index rows = block_rows(), blocks = (c + rows - 1) / rows;
        const double per_row = static_cast<double>(layout_.m) *
                               static_cast<double>(layout_.acf_lags + 4 + layout_.p * (layout_.xcorr_lags + 3));
        const Index workers = detail::worker_count(blocks, static_cast<double>(c) * per_row);
        if (workers == 1) {
            for (Index b = 0; b < blocks; ++b) merge_owned(block(b * rows, std::min(rows, c - b * rows)));
            return;
        }
        const Index batch = 4 * workers;  // bounds the states held at once
        std::vector<stream_state> states;
        for (Index first = 0; first < blocks; first += batch) {
            const Index count = std::min(batch, blocks - first);
            states.assign(static_cast<std::size_t>(count), stream_state(layout_));
            detail::for_ranges(count, workers, [&](Index, Index b0, Index b1) {
                for (Index b = b0; b < b1; ++b) {
                    const Index a = (first + b) * rows;
                    states[static_cast<std::size_t>(b)] = block(a, std::min(rows, c - a));
                }
            });
            for (auto& st : states) merge_owned(std::move(st));
        }
    }

    /// `from_block` of joint-major copies (m, c) of e and tau and (m·p, c) of the regressor (0 rows
    /// without one), which it centres in place.
    static stream_state from_joint_major(const stream_layout& layout, JointRows& xe, JointRows& xt, JointRows& xy) {
        stream_state st(layout);
        const Index c = xe.cols(), m = layout.m, mp = xy.rows(), p = mp ? layout.p : 0;
        if (c == 0) return st;
        const Index le = layout.acf_lags, lx = layout.xcorr_lags;
        st.n = c;
        st.lengths = {c};
        // The raw boundary rows, before centring.
        const Index kh = std::min(le, c);
        st.head_e.resize(static_cast<std::size_t>(kh * m));
        st.tail_e.resize(static_cast<std::size_t>(kh * m));
        for (Index i = 0; i < kh; ++i)
            for (Index j = 0; j < m; ++j) {
                st.head_e[i * m + j] = xe(j, i);
                st.tail_e[i * m + j] = xe(j, c - kh + i);
            }
        if (mp) {
            const Index ky = std::min(lx, c);
            st.tail_y.resize(static_cast<std::size_t>(ky * mp));
            for (Index i = 0; i < ky; ++i)
                for (Index q = 0; q < mp; ++q) st.tail_y[i * mp + q] = xy(q, c - ky + i);
        }
        centre_rows(xe, st.k_e, st.min_e, st.max_e, st.exp_e);
        const Index top = std::min(le, c - 1);
        for (Index j = 0; j < m; ++j) {
            const double* x = xe.row(j).data();
            Index l = 0;
            for (double tile[4]; l + 3 <= top; l += 4) {
                detail::stream_lag_tile(x, c, l, tile);
                for (int k = 0; k < 4; ++k) st.prod_e.hi[(l + k) * m + j] = tile[k];
            }
            for (; l <= top; ++l) st.prod_e.hi[l * m + j] = detail::stream_dot(x + l, x, c - l);
        }
        boundary_sums(xe, le, st.cur_e.hi.data(), st.lag_e.hi.data(), true);
        for (Index l = 0; l <= le; ++l) st.pairs[l] = std::max<long long>(c - l, 0);
        if (layout.gram)
            for (Index i = 0; i < m; ++i)
                for (Index k = i; k < m; ++k)
                    st.gram.hi[i * m + k] = st.gram.hi[k * m + i] =
                        detail::stream_dot(xe.row(i).data(), xe.row(k).data(), c);
        centre_rows(xt, st.k_t, st.min_t, st.max_t, st.exp_t);
        for (Index j = 0; j < m; ++j) {
            const double* x = xt.row(j).data();
            st.sum_t.hi[j] = xt.row(j).sum();
            st.sq_t.hi[j] = detail::stream_dot(x, x, c);
        }
        if (mp) {
            centre_rows(xy, st.k_y, st.min_y, st.max_y, st.exp_y);  // row j·p + c: joint j, column c
            for (Index q = 0; q < mp; ++q) st.sq_y.hi[q] = detail::stream_dot(xy.row(q).data(), xy.row(q).data(), c);
            boundary_sums(xy, lx, nullptr, st.lag_y.hi.data(), false);
            const Index topx = std::min(lx, c - 1);
            for (Index j = 0; j < m; ++j) {
                const double* x = xe.row(j).data();
                for (Index col = 0; col < p; ++col) {
                    const Index q = j * p + col;
                    const double* yq = xy.row(q).data();
                    for (Index l = 0; l <= topx; ++l) st.prod_ey.hi[l * mp + q] = detail::stream_dot(x + l, yq, c - l);
                }
            }
        }
        return st;
    }

    stream_layout layout_;

    void check_rows(Index re, Index ce, Index rt, Index ct, Index ry, Index cy, bool has_y) const {
        const Index m = layout_.m, mp = m * layout_.p;
        if (ce != m) throw invalid_shape("e must have m=" + std::to_string(m) + " columns, got " + shape_text(re, ce));
        if (rt != re || ct != m)
            throw invalid_shape("tau must have the shape of e " + shape_text(re, ce) + ", got " + shape_text(rt, ct));
        if (has_y && (ry != re || cy != mp))
            throw invalid_shape("y must have " + std::to_string(re) + " rows and m*p=" + std::to_string(mp) +
                                " columns, got " + shape_text(ry, cy));
        if (!has_y && layout_.p != 0)
            throw invalid_shape("y must be given: the layout has p=" + std::to_string(layout_.p) + " columns");
    }

    void check_same_layout(const stream_state& o) const {
        const auto& a = layout_;
        const auto& b = o.layout_;
        if (a.m != b.m || a.p != b.p || a.acf_lags != b.acf_lags || a.xcorr_lags != b.xcorr_lags || a.gram != b.gram)
            throw invalid_shape("stream_state.merge needs states of the same layout");
    }

    /// Scales each row of x by 2^-k, k the exponent of its largest |x| (0 for a row of zeros),
    /// and centres it on its mean; writes the centres (scaled), the raw minima and maxima and k.
    template <class Rows>
    static void centre_rows(Rows& x, std::vector<double>& centre, std::vector<double>& lo, std::vector<double>& hi,
                            std::vector<long long>& exps) {
        const double c = static_cast<double>(x.cols());
        for (Index r = 0; r < x.rows(); ++r) {
            double sum = 0.0;
            detail::stream_extremes(x.row(r).data(), x.cols(), lo[r], hi[r], sum);
            const double largest = std::max(std::fabs(lo[r]), std::fabs(hi[r]));
            int k = 0;
            if (largest > 0.0 && largest <= std::numeric_limits<double>::max()) std::frexp(largest, &k);
            exps[r] = k;
            double* row = x.row(r).data();
            if (k > -1000 && k < 1000) {
                // 2^-k is a normal number: the product is exactly std::ldexp's
                const double f = std::ldexp(1.0, -k);
                centre[r] = (sum * f) / c;
                for (Index i = 0; i < x.cols(); ++i) row[i] = row[i] * f - centre[r];
            } else {
                for (Index i = 0; i < x.cols(); ++i) row[i] = std::ldexp(row[i], -k);
                centre[r] = std::ldexp(sum, -k) / c;
                x.row(r).array() -= centre[r];
            }
        }
    }

    /// A raw boundary value in the units 2^k of its column.
    static double scaled(double x, long long k) noexcept { return k ? std::ldexp(x, static_cast<int>(-k)) : x; }

    /// For rows x (k, c) of one segment: Σ x_t over the current elements (t ≥ ℓ) and over the
    /// lagged elements (t < c − ℓ) of the lag-ℓ pairs, ℓ = 0..lags, lag-major (lags+1, k); 0
    /// where a lag has no pair.
    template <class Rows>
    static void boundary_sums(const Rows& x, Index lags, double* cur, double* lag, bool want_cur) {
        const Index k = x.rows(), c = x.cols(), top = std::min(lags, c - 1);
        for (Index r = 0; r < k; ++r) {
            const double total = x.row(r).sum();
            if (want_cur) cur[r] = total;
            lag[r] = total;
            double head = 0.0, tail = 0.0;
            for (Index l = 1; l <= top; ++l) {
                head += x(r, l - 1);
                tail += x(r, c - l);
                if (want_cur) cur[l * k + r] = total - head;
                lag[l * k + r] = total - tail;
            }
        }
    }

    void add_sums(const stream_state& b) {
        prod_e.add_sum(b.prod_e);
        cur_e.add_sum(b.cur_e);
        lag_e.add_sum(b.lag_e);
        sum_t.add_sum(b.sum_t);
        sq_t.add_sum(b.sq_t);
        sq_y.add_sum(b.sq_y);
        lag_y.add_sum(b.lag_y);
        prod_ey.add_sum(b.prod_ey);
        gram.add_sum(b.gram);
        for (std::size_t l = 0; l < pairs.size(); ++l) pairs[l] += b.pairs[l];
        n += b.n;
        auto extremes = [](std::vector<double>& lo, std::vector<double>& hi, const std::vector<double>& blo,
                           const std::vector<double>& bhi) {
            for (std::size_t i = 0; i < lo.size(); ++i) {
                lo[i] = std::min(lo[i], blo[i]);
                hi[i] = std::max(hi[i], bhi[i]);
            }
        };
        extremes(min_e, max_e, b.min_e, b.max_e);
        extremes(min_t, max_t, b.min_t, b.max_t);
        extremes(min_y, max_y, b.min_y, b.max_y);
    }

    /// The lagged products whose current element is in b's first segment and whose lagged element
    /// is in this state's last segment (both already on the same centres).
    void add_junction(const stream_state& b) {
        const Index le = layout_.acf_lags, lx = layout_.xcorr_lags, m = layout_.m, p = layout_.p, mp = m * p;
        if (le == 0) return;
        const Index n_head = static_cast<Index>(b.head_e.size()) / m, n_tail = static_cast<Index>(tail_e.size()) / m;
        // Centred joint-major copies of b's first rows and this state's last rows: each lag's
        // junction products and sums are then runs of contiguous values (L²/2 pairs per joint).
        std::vector<double> h(static_cast<std::size_t>(m * n_head)), g(static_cast<std::size_t>(m * n_tail));
        for (Index j = 0; j < m; ++j) {
            for (Index i = 0; i < n_head; ++i) h[j * n_head + i] = scaled(b.head_e[i * m + j], exp_e[j]) - k_e[j];
            for (Index t = 0; t < n_tail; ++t) g[j * n_tail + t] = scaled(tail_e[t * m + j], exp_e[j]) - k_e[j];
        }
        for (Index l = 1; l <= le; ++l) {
            const Index i0 = std::max<Index>(0, l - n_tail), i1 = std::min(l, n_head);
            if (i0 >= i1) continue;
            for (Index j = 0; j < m; ++j) {
                const double* hj = h.data() + j * n_head + i0;  // current elements, rows i0..i1 of b
                const double* gj = g.data() + j * n_tail + (n_tail - l + i0);  // their lagged partners
                prod_e.add(l * m + j, detail::stream_dot(hj, gj, i1 - i0));
                cur_e.add(l * m + j, detail::stream_sum(hj, i1 - i0));
                lag_e.add(l * m + j, detail::stream_sum(gj, i1 - i0));
            }
            pairs[l] += i1 - i0;
        }
        if (!mp || lx == 0) return;
        const Index ny = static_cast<Index>(tail_y.size()) / mp;
        std::vector<double> py(mp), sy(mp);
        for (Index l = 1; l <= lx; ++l) {
            const Index i0 = std::max<Index>(0, l - ny), i1 = std::min(l, n_head);
            if (i0 >= i1) continue;
            std::fill(py.begin(), py.end(), 0.0);
            std::fill(sy.begin(), sy.end(), 0.0);
            for (Index i = i0; i < i1; ++i) {
                const Index t = ny - l + i;
                for (Index j = 0; j < m; ++j) {
                    const double h = scaled(b.head_e[i * m + j], exp_e[j]) - k_e[j];
                    for (Index col = 0; col < p; ++col) {
                        const Index q = j * p + col;
                        const double g = scaled(tail_y[t * mp + q], exp_y[q]) - k_y[q];
                        py[q] += h * g;
                        sy[q] += g;
                    }
                }
            }
            for (Index q = 0; q < mp; ++q) {
                prod_ey.add(l * mp + q, py[q]);
                lag_y.add(l * mp + q, sy[q]);
            }
        }
    }

    /// Keeps the last `k` rows of width w of a row-major buffer.
    static void keep_last(std::vector<double>& rows, Index k, Index w) {
        const Index have = w ? static_cast<Index>(rows.size()) / w : 0;
        if (have > k) rows.erase(rows.begin(), rows.begin() + (have - k) * w);
    }

    /// Segment lengths and boundary rows of the concatenation.
    void join_boundaries(const stream_state& b, bool join) {
        const Index le = layout_.acf_lags, lx = layout_.xcorr_lags, m = layout_.m, mp = m * layout_.p;
        const bool single_a = lengths.size() == 1, single_b = b.lengths.size() == 1;
        if (join && single_a) {
            head_e.insert(head_e.end(), b.head_e.begin(), b.head_e.end());
            if (static_cast<Index>(head_e.size()) > le * m) head_e.resize(static_cast<std::size_t>(le * m));
        }
        if (join && single_b) {
            tail_e.insert(tail_e.end(), b.tail_e.begin(), b.tail_e.end());
            keep_last(tail_e, le, m);
            tail_y.insert(tail_y.end(), b.tail_y.begin(), b.tail_y.end());
            keep_last(tail_y, lx, mp);
        } else {
            tail_e = b.tail_e;
            tail_y = b.tail_y;
        }
        if (join) {
            lengths.back() += b.lengths.front();
            lengths.insert(lengths.end(), b.lengths.begin() + 1, b.lengths.end());
        } else {
            lengths.insert(lengths.end(), b.lengths.begin(), b.lengths.end());
        }
        end_break = b.end_break;
    }
};

}  // namespace dynval
