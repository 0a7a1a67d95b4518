// Autocorrelation of the residual (contract §3.4), cross-correlation with regressor columns
// (§3.6), the white-noise band and the portmanteau tests (§3.5).
//
// Lagged products are computed blocked-direct, after a first pass (joint_accumulator) that
// gives the overall means, the constancy tests and the finiteness check:
// * C-contiguous (N, m) data: blocks of rows are centred into a buffer that also holds the
//   previous max_lag rows (the tail that lagged products need), and tiles of several lags are
//   formed at once with their partial sums in registers (narrow_lag_tiles for up to 15 joints,
//   lag_tile_wide from 16 columns); one read of the data;
// * any other expression: each centred column is copied contiguous and summed chunk by chunk.
// Block sums are Neumaier-compensated. At 50 lags this beats an FFT for N up to millions
// (benchmarks/README.md). Means are overall (one per joint over all samples); products never
// join two segments.
//
// Streaming (logs larger than memory, partial results merged across processes) is
// lag_accumulator.hpp, a layer over stream_state.hpp: centred lag sums plus the head/tail rows of
// each range, centred on the overall mean at the end.
#pragma once

#include "accumulator.hpp"
#include "distributions.hpp"
#include "errors.hpp"
#include "options.hpp"
#include "parallel.hpp"
#include "segments.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace dynval {

using row_matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

namespace detail {

/// out[ℓ] = Σ_{products} x_k · y_{k−ℓ} for ℓ = 0..max_lag, products within segments.
inline void lagged_sums(const double* x, const double* y, const std::vector<Index>& starts, Index n, Index max_lag,
                        std::vector<double>& out) {
    constexpr Index chunk = 4096;
    std::vector<compensated> acc(static_cast<std::size_t>(max_lag + 1));
    const std::vector<Index> lengths = segment_lengths(starts, n);
    for (std::size_t s = 0; s < starts.size(); ++s) {
        const Index s0 = starts[s], s1 = starts[s] + lengths[s];
        for (Index a = s0; a < s1; a += chunk) {
            const Index b = std::min(a + chunk, s1);
            for (Index lag = 0; lag <= max_lag; ++lag) {
                const Index lo = std::max(a, s0 + lag);
                if (lo >= b) break;
                const Eigen::Map<const Eigen::VectorXd> xs(x + lo, b - lo), ys(y + lo - lag, b - lo);
                acc[static_cast<std::size_t>(lag)].add(xs.dot(ys));
            }
        }
    }
    out.resize(acc.size());
    for (std::size_t i = 0; i < acc.size(); ++i) out[i] = acc[i].value();
}

/// Column j of `a` minus its mean, copied contiguous. The mean's own rounding (half an ulp of
/// an offset, which lag products do not cancel) is removed by subtracting the compensated mean
/// of the first deviations (the corrected two-pass algorithm).
template <class D>
void centred_column(const Eigen::MatrixBase<D>& a, Index j, double mean, Eigen::VectorXd& buf) {
    const Index n = a.rows();
    buf.resize(n);
    for (Index k = 0; k < n; ++k) buf(k) = a.coeff(k, j) - mean;
    compensated s;
    constexpr Index chunk = 1024;
    for (Index k = 0; k < n; k += chunk) s.add(buf.segment(k, std::min(chunk, n - k)).sum());
    buf.array() -= s.value() / static_cast<double>(n);
}

inline Index longest(const std::vector<Index>& starts, Index n) {
    const auto lengths = segment_lengths(starts, n);
    return *std::max_element(lengths.begin(), lengths.end());
}

template <class D>
joint_moments checked_signal(const Eigen::MatrixBase<D>& e, const std::string& function) {
    check_columns(e.rows(), e.cols(), "e");
    check_min_samples(e.rows(), 2, function);
    joint_moments mo = accumulate_signal(e);
    mo.throw_if_nonfinite("e", "e");
    return mo;
}

inline long long check_max_lag(long long max_lag, Index limit) {
    return require_int(max_lag, "max_lag", 0, limit, "an integer with 0 <= max_lag < " + std::to_string(limit));
}

/// Fixed lane count: the partial sums stay in registers.
template <int Lanes>
DYNVAL_FMA_CLONES inline void lane_products_fixed(const double* DYNVAL_RESTRICT a, const double* DYNVAL_RESTRICT b,
                                                     Index count, double* DYNVAL_RESTRICT acc) {
    double part[Lanes] = {};
    const Index chunks = count / Lanes;
    for (Index c = 0; c < chunks; ++c) {
        const double* ac = a + c * Lanes;
        const double* bc = b + c * Lanes;
        for (int l = 0; l < Lanes; ++l) part[l] += ac[l] * bc[l];
    }
    for (Index i = chunks * Lanes; i < count; ++i) part[i - chunks * Lanes] += a[i] * b[i];
    for (int l = 0; l < Lanes; ++l) acc[l] += part[l];
}

/// acc[i mod lanes] += a[i]·b[i] for i < count: independent lanes, so the loop vectorises.
DYNVAL_FMA_CLONES inline void lane_products(const double* DYNVAL_RESTRICT a, const double* DYNVAL_RESTRICT b,
                                               Index count, Index lanes, double* DYNVAL_RESTRICT acc) {
    switch (lanes) {  // 2m lanes for m = 1..8 joints
        case 2: return lane_products_fixed<2>(a, b, count, acc);
        case 4: return lane_products_fixed<4>(a, b, count, acc);
        case 6: return lane_products_fixed<6>(a, b, count, acc);
        case 8: return lane_products_fixed<8>(a, b, count, acc);
        case 10: return lane_products_fixed<10>(a, b, count, acc);
        case 12: return lane_products_fixed<12>(a, b, count, acc);
        case 14: return lane_products_fixed<14>(a, b, count, acc);
        case 16: return lane_products_fixed<16>(a, b, count, acc);
        default: break;
    }
    const Index chunks = count / lanes;
    for (Index c = 0; c < chunks; ++c) {
        const double* ac = a + c * lanes;
        const double* bc = b + c * lanes;
        for (Index l = 0; l < lanes; ++l) acc[l] += ac[l] * bc[l];
    }
    for (Index i = chunks * lanes; i < count; ++i) acc[i - chunks * lanes] += a[i] * b[i];
}

/// Lags per tile of the narrow (up to 15 joints) lag-sum kernel.
constexpr Index narrow_tile_lags = 8;

/// acc[ℓ·4m + l] += Σ_{i ≡ l mod 4m} x[i]·x[i − ℓ·m] for i < rows·m and the TL lags ℓ = l0.. (x holds
/// rows of m joints; lane l is joint l mod m). Four rows are m vectors; for each vector position
/// the TL partial sums stay in registers while it steps through the rows, so one loaded value of
/// x feeds TL multiply-adds (the lane-wise product of one lag needed two loads per multiply-add).
template <int TL>
DYNVAL_ALWAYS_INLINE void narrow_lag_tile(const double* DYNVAL_RESTRICT x, Index m, Index rows, Index l0,
                                          double* DYNVAL_RESTRICT acc) {
    const Index lanes = 4 * m, steps = rows / 4;
#if defined(DYNVAL_VECTOR_TYPES)
    for (Index v = 0; v < m; ++v) {
        vec4 s[TL] = {};
        for (Index k = 0; k < steps; ++k) {
            const double* xk = x + k * lanes + 4 * v;
            vec4 xv;
            load4(xv, xk);
            for (int t = 0; t < TL; ++t) {
                vec4 yv;
                load4(yv, xk - (l0 + t) * m);
                s[t] += xv * yv;
            }
        }
        for (int t = 0; t < TL; ++t)
            for (int i = 0; i < 4; ++i) acc[(l0 + t) * lanes + 4 * v + i] += s[t][i];
    }
#else
    for (int t = 0; t < TL; ++t)
        for (Index i = 0; i < steps * lanes; ++i) acc[(l0 + t) * lanes + i % lanes] += x[i] * x[i - (l0 + t) * m];
#endif
    for (Index i = steps * lanes; i < rows * m; ++i)  // the last rows mod 4
        for (int t = 0; t < TL; ++t) acc[(l0 + t) * lanes + (i - steps * lanes)] += x[i] * x[i - (l0 + t) * m];
}

/// narrow_lag_tile for the lags [l0, l1) (at most narrow_tile_lags of them) of `rows` rows from x.
DYNVAL_FMA_CLONES inline void narrow_lag_tiles(const double* DYNVAL_RESTRICT x, Index m, Index rows, Index l0, Index l1,
                                               double* DYNVAL_RESTRICT acc) {
    switch (l1 - l0) {
        case 8: return narrow_lag_tile<8>(x, m, rows, l0, acc);
        case 7: return narrow_lag_tile<7>(x, m, rows, l0, acc);
        case 6: return narrow_lag_tile<6>(x, m, rows, l0, acc);
        case 5: return narrow_lag_tile<5>(x, m, rows, l0, acc);
        case 4: return narrow_lag_tile<4>(x, m, rows, l0, acc);
        case 3: return narrow_lag_tile<3>(x, m, rows, l0, acc);
        case 2: return narrow_lag_tile<2>(x, m, rows, l0, acc);
        case 1: return narrow_lag_tile<1>(x, m, rows, l0, acc);
        default: return;
    }
}

/// Lags per tile of the wide (16 columns or more) lag-sum kernel: 7 sums and 7 lagged rows, plus
/// the row loaded, fill 15 of the 16 AVX registers (6 and 8 measured slower).
constexpr Index wide_tile_lags = 7;

/// acc[ℓ·m + j] += Σ_{u ∈ [u0, u1)} r[u·m + j]·r[(u − ℓ)·m + j] for the TL lags ℓ = l0..l0+TL−1 and
/// every column j, rows counted from `r` (which must hold the rows from u0 − l0 − TL + 1). For each
/// panel of 4 columns the TL partial sums and the TL lagged rows they need stay in registers while
/// the rows go by: row u − ℓ of lag ℓ is row (u − 1) − (ℓ − 1) of lag ℓ − 1, so each step loads
/// two rows (u and u − l0) for TL multiply-adds. For wide data (the regressor's 490 columns), where
/// one lane per column does not fit in registers.
template <int TL>
DYNVAL_ALWAYS_INLINE void wide_lag_tile(const double* DYNVAL_RESTRICT r, Index m, Index u0, Index u1, Index l0,
                                        double* DYNVAL_RESTRICT acc) {
    Index c0 = 0;
#if defined(DYNVAL_VECTOR_TYPES)
    for (; c0 + 4 <= m; c0 += 4) {
        vec4 s[TL] = {}, w[TL] = {};
        for (int k = 0; k + 1 < TL; ++k) load4(w[k], r + (u0 - 1 - l0 - k) * m + c0);
        for (Index u = u0; u < u1; ++u) {
            for (int t = TL - 1; t > 0; --t) w[t] = w[t - 1];  // w[t] = row u − l0 − t
            load4(w[0], r + (u - l0) * m + c0);
            vec4 x;
            load4(x, r + u * m + c0);
            for (int t = 0; t < TL; ++t) s[t] += x * w[t];
        }
        for (int t = 0; t < TL; ++t)
            for (int i = 0; i < 4; ++i) acc[(l0 + t) * m + c0 + i] += s[t][i];
    }
#endif
    for (; c0 < m; ++c0)  // the last m mod 4 columns (every column without vector types)
        for (int t = 0; t < TL; ++t) {
            double part = 0.0;
            for (Index u = u0; u < u1; ++u) part += r[u * m + c0] * r[(u - l0 - t) * m + c0];
            acc[(l0 + t) * m + c0] += part;
        }
}

/// wide_lag_tile for the lags [l0, l1) (at most wide_tile_lags of them) over rows [u0, u1).
DYNVAL_FMA_CLONES inline void lag_tile_wide(const double* DYNVAL_RESTRICT r, Index m, Index u0, Index u1, Index l0,
                                            Index l1, double* DYNVAL_RESTRICT acc) {
    static_assert(wide_tile_lags >= 1 && wide_tile_lags <= 8, "wide_tile_lags: 1 to 8 lags per tile");
    switch (l1 - l0) {
        case 8: return wide_lag_tile<8>(r, m, u0, u1, l0, acc);
        case 7: return wide_lag_tile<7>(r, m, u0, u1, l0, acc);
        case 6: return wide_lag_tile<6>(r, m, u0, u1, l0, acc);
        case 5: return wide_lag_tile<5>(r, m, u0, u1, l0, acc);
        case 4: return wide_lag_tile<4>(r, m, u0, u1, l0, acc);
        case 3: return wide_lag_tile<3>(r, m, u0, u1, l0, acc);
        case 2: return wide_lag_tile<2>(r, m, u0, u1, l0, acc);
        case 1: return wide_lag_tile<1>(r, m, u0, u1, l0, acc);
        default: return;
    }
}

/// One lag ℓ of every column over rows [u0, u1): acc[ℓ·m + j] += Σ r[u·m + j]·r[(u − ℓ)·m + j].
DYNVAL_FMA_CLONES inline void lag_row_wide(const double* DYNVAL_RESTRICT r, Index m, Index u0, Index u1, Index lag,
                                              double* DYNVAL_RESTRICT acc) {
    double* a = acc + lag * m;
    for (Index u = u0; u < u1; ++u) {
        const double* x = r + u * m;
        const double* y = r + (u - lag) * m;
        for (Index j = 0; j < m; ++j) a[j] += x[j] * y[j];
    }
}

/// The blocks shared by the lag-sum kernels of C-contiguous (N, m) data, read once: blocks of rows
/// are centred into a buffer that also keeps the previous max_lag rows (the tail lagged products
/// need); `products(rows, a, nb, s0, s1, acc)` adds the products of each segment [s0, s1) that
/// meets the block [a, a + nb) (row k at rows + (k − a)·m) into the block's partial sums `acc`, and
/// `fold(acc, total)` adds those to the compensated totals (lag ℓ, joint j at ℓ·m + j).
template <class Products, class Fold>
Eigen::MatrixXd blocked_lag_sums(const double* x, Index n, Index m, const joint_moments& mo,
                                 const std::vector<Index>& starts, Index max_lag, std::size_t acc_size,
                                 Products&& products, Fold&& fold) {
    // Blocks of at most 512 rows and about 512 KB (wide data: 133 rows of 490 columns), so a block
    // and its tail stay in the L2 cache while each tile of lags runs over it.
    const Index block = std::clamp<Index>((Index{1} << 16) / m, 64, 512);
    const auto lengths = segment_lengths(starts, n);
    std::vector<double> buf(static_cast<std::size_t>((block + max_lag) * m)), acc(acc_size);
    std::vector<compensated> total(static_cast<std::size_t>((max_lag + 1) * m));
    for (Index a = 0; a < n; a += block) {
        const Index nb = std::min(block, n - a);
        double* rows = buf.data() + max_lag * m;
        for (Index i = 0; i < nb; ++i)
            for (Index j = 0; j < m; ++j)
                rows[i * m + j] = (x[(a + i) * m + j] - mo.tau_shift(j)) - mo.tau_dev(j);
        std::fill(acc.begin(), acc.end(), 0.0);
        for (std::size_t s = 0; s < starts.size(); ++s) {
            const Index s0 = starts[s], s1 = starts[s] + lengths[s];
            if (s1 > a && s0 < a + nb) products(rows, a, nb, s0, s1, acc.data());
        }
        fold(acc.data(), total);
        // Keep the last max_lag rows (of this block and before) for the next block's lags.
        // (std::copy is safe for this overlapping move towards the front.)
        if (max_lag > 0) std::copy(buf.begin() + nb * m, buf.begin() + (nb + max_lag) * m, buf.begin());
    }
    Eigen::MatrixXd sums(max_lag + 1, m);
    for (Index lag = 0; lag <= max_lag; ++lag)
        for (Index j = 0; j < m; ++j) sums(lag, j) = total[static_cast<std::size_t>(lag * m + j)].value();
    return sums;
}

/// Lag sums of C-contiguous (N, m) data in one pass (blocked_lag_sums). Up to 15 joints each lag
/// takes tiles of 8 lags over 4 rows at a time (narrow_lag_tiles; lane l is joint l mod m), from 16
/// columns (a regressor's) lag_tile_wide tiles of wide_tile_lags lags; lane_products and
/// lag_row_wide the first rows of a segment, where the lags of a tile start at different rows.
inline Eigen::MatrixXd lag_sums_rows(const double* x, Index n, Index m, const joint_moments& mo,
                                     const std::vector<Index>& starts, Index max_lag) {
    const auto size = static_cast<std::size_t>((max_lag + 1) * m);
    if (m >= 16) {
        constexpr Index TL = wide_tile_lags;
        // Tiles of TL lags (l0 = 0, TL, ...) and the lags after the last whole tile. Threads take
        // contiguous runs of tiles, the last one also the lags left over; each forms its lags'
        // sums in the one-thread order and leaves the other lags 0, so the parts add exactly.
        const Index tiles = (max_lag + 1) / TL;
        const double work = static_cast<double>(n) * static_cast<double>(m) * static_cast<double>(max_lag + 1);
        const Index workers = tiles > 0 ? worker_count(tiles, work) : 1;
        std::vector<Eigen::MatrixXd> parts(static_cast<std::size_t>(workers));
        for_ranges(std::max<Index>(tiles, 1), workers, [&](Index w, Index tile_begin, Index tile_end) {
            const Index lag_end = w == workers - 1 ? max_lag + 1 : tile_end * TL;
            const auto tiled = [&](const double* rows, Index a, Index nb, Index s0, Index s1, double* acc) {
                const Index hi = std::min(a + nb, s1) - a;  // rows of this block, relative to a
                for (Index l0 = tile_begin * TL; l0 < lag_end; l0 += TL) {
                    const Index l1 = std::min(l0 + TL, lag_end);
                    // rows where every lag of the tile has a partner in the segment; before them, lag by lag
                    const Index tile_from = std::max(a, s0 + l1 - 1) - a;
                    for (Index lag = l0; lag < l1; ++lag) {
                        const Index from = std::max(a, s0 + lag) - a;
                        if (from < std::min(tile_from, hi)) lag_row_wide(rows, m, from, std::min(tile_from, hi), lag, acc);
                    }
                    if (tile_from < hi) lag_tile_wide(rows, m, tile_from, hi, l0, l1, acc);
                }
            };
            const auto fold = [](const double* acc, std::vector<compensated>& total) {
                for (std::size_t i = 0; i < total.size(); ++i) total[i].add(acc[i]);
            };
            parts[static_cast<std::size_t>(w)] = blocked_lag_sums(x, n, m, mo, starts, max_lag, size, tiled, fold);
        });
        for (std::size_t w = 1; w < parts.size(); ++w) parts[0] += parts[w];
        return parts[0];
    }
    // Four rows (4m lanes, m vectors) per step of the tiled kernel; lane l is joint l mod m.
    const Index lanes = 4 * m;
    const auto laned = [&](const double* rows, Index a, Index nb, Index s0, Index s1, double* acc) {
        const Index hi = std::min(a + nb, s1);
        for (Index l0 = 0; l0 <= max_lag; l0 += narrow_tile_lags) {
            const Index l1 = std::min(l0 + narrow_tile_lags, max_lag + 1);
            // rows where every lag of the tile has a partner in the segment; before them, lag by lag
            const Index tile_from = std::max(a, s0 + l1 - 1);
            for (Index lag = l0; lag < l1; ++lag) {
                const Index lo = std::max(a, s0 + lag), head_end = std::min(tile_from, hi);
                if (lo >= head_end) continue;
                const double* cur = rows + (lo - a) * m;
                lane_products(cur, cur - lag * m, (head_end - lo) * m, lanes, acc + lag * lanes);
            }
            if (tile_from < hi) narrow_lag_tiles(rows + (tile_from - a) * m, m, hi - tile_from, l0, l1, acc);
        }
    };
    const auto fold = [&](const double* acc, std::vector<compensated>& total) {
        for (Index lag = 0; lag <= max_lag; ++lag)
            for (Index j = 0; j < m; ++j) {
                const double* l = acc + lag * lanes + j;
                total[static_cast<std::size_t>(lag * m + j)].add(((l[0] + l[m]) + l[2 * m]) + l[3 * m]);
            }
    };
    return blocked_lag_sums(x, n, m, mo, starts, max_lag, static_cast<std::size_t>((max_lag + 1) * lanes), laned,
                            fold);
}

/// Biased lag sums S_ℓ (ℓ = 0..max_lag) of every joint, columns of the result.
template <class D>
Eigen::MatrixXd lag_sums(const Eigen::MatrixBase<D>& e, const joint_moments& mo, const std::vector<Index>& starts,
                         Index max_lag) {
    if constexpr ((int(D::Flags) & Eigen::DirectAccessBit) && (int(D::Flags) & Eigen::RowMajorBit)) {
        if (e.derived().innerStride() == 1 && (e.rows() <= 1 || e.derived().outerStride() == e.cols()))
            return lag_sums_rows(e.derived().data(), e.rows(), e.cols(), mo, starts, max_lag);
    }
    Eigen::MatrixXd sums(max_lag + 1, e.cols());
    Eigen::VectorXd buf;
    std::vector<double> out;
    for (Index j = 0; j < e.cols(); ++j) {
        centred_column(e, j, mo.tau_mean(j), buf);
        lagged_sums(buf.data(), buf.data(), starts, e.rows(), max_lag, out);
        for (Index l = 0; l <= max_lag; ++l) sums(l, j) = out[static_cast<std::size_t>(l)];
    }
    return sums;
}

/// lag_sums of `e`, with the joints whose centred sum of squares is tiny (data near 1e-160,
/// whose squares underflow) scaled by a power of two first: ρ̂ does not depend on the scale.
template <class D>
Eigen::MatrixXd scaled_lag_sums(const Eigen::MatrixBase<D>& e, const joint_moments& mo,
                                const std::vector<Index>& starts, Index max_lag) {
    Eigen::ArrayXi k = Eigen::ArrayXi::Zero(e.cols());
    for (Index j = 0; j < e.cols(); ++j)
        if (mo.tau_min(j) != mo.tau_max(j))
            k(j) = scale_exponent(mo.tau_m2(j), largest_abs(mo.tau_min(j), mo.tau_max(j)));
    if ((k == 0).all()) return lag_sums(e, mo, starts, max_lag);
    const Eigen::MatrixXd scaled = scaled_columns(e, k);
    return lag_sums(scaled, accumulate_signal(scaled), starts, max_lag);
}

/// Column j of `a` centred into `buf`; returns Σ buf², the lag-0 sum that normalises the
/// cross-correlation. A column whose centred sum of squares is tiny (data near 1e-160) is
/// scaled by a power of two before it is centred, so its mean and squares keep their digits.
template <class D>
double centred_for_correlation(const Eigen::MatrixBase<D>& a, Index j, const joint_moments& mo, Eigen::VectorXd& buf) {
    if (!(mo.tau_m2(j) < tiny_sum_of_squares) || mo.tau_min(j) == mo.tau_max(j)) {
        centred_column(a, j, mo.tau_mean(j), buf);
        return mo.tau_m2(j);
    }
    const int k = scale_exponent(0.0, largest_abs(mo.tau_min(j), mo.tau_max(j)));
    const Eigen::MatrixXd scaled = scaled_columns(a.col(j), Eigen::ArrayXi::Constant(1, k));
    compensated sum;
    for (Index i = 0; i < scaled.rows(); ++i) sum.add(scaled(i, 0));
    centred_column(scaled, 0, sum.value() / static_cast<double>(scaled.rows()), buf);
    return buf.squaredNorm();
}

/// Columns per panel of the packed regressor block: two 4-double vectors, a tile's width.
constexpr Index lag_panel = 8;

/// acc[(l0 + t)·p + c0 + k] += Σ_{u < rows} e[u + l0 + t]·y[u·8 + k] for t < TL, k < width: TL lags
/// of one packed panel (8 columns, row u at y + 8u; columns from `width` on are zero padding). The
/// 2·TL partial sums stay in registers across the rows: each loaded row of the panel feeds TL
/// multiply-adds per value and each residual value 8. Inlined into the cloned caller.
template <int TL>
DYNVAL_ALWAYS_INLINE void lag_panel_tile(const double* DYNVAL_RESTRICT e, const double* DYNVAL_RESTRICT y, Index rows,
                                         Index l0, Index p, Index c0, Index width, double* DYNVAL_RESTRICT acc) {
#if defined(DYNVAL_VECTOR_TYPES)
    vec4 s[TL][2] = {};
    for (Index u = 0; u < rows; ++u) {
        vec4 y0, y1;
        load4(y0, y + u * lag_panel);
        load4(y1, y + u * lag_panel + 4);
        // The empty asm hides that row u + 1 reads the values of row u shifted by one: otherwise
        // GCC's predictive commoning (-O3) keeps them in registers across rows, and the extra live
        // registers spill the sums to the stack (the products ran 1.6x slower).
        const double* eu = e + u + l0;
        __asm__("" : "+r"(eu));
        for (int t = 0; t < TL; ++t) {
            const double ev = eu[t];
            const vec4 et = {ev, ev, ev, ev};  // a broadcast (vec4{} + ev would add 0.0 first)
            s[t][0] += et * y0;
            s[t][1] += et * y1;
        }
    }
    for (int t = 0; t < TL; ++t)
        for (Index k = 0; k < width; ++k) acc[(l0 + t) * p + c0 + k] += s[t][k / 4][k % 4];
#else
    for (int t = 0; t < TL; ++t)
        for (Index k = 0; k < width; ++k) {
            double part = 0.0;
            for (Index u = 0; u < rows; ++u) part += e[u + l0 + t] * y[u * lag_panel + k];
            acc[(l0 + t) * p + c0 + k] += part;
        }
#endif
}

/// acc[ℓ·p + c] += Σ_{u < rows} e[u + ℓ]·Y[u, c] for ℓ < n_lags, c < p: the lagged products of one
/// joint's residual with a block of its centred regressor rows, packed in panels of 8 columns (panel
/// k holds columns 8k..8k+7, row u at y + (k·panel_stride + u)·8; the last panel zero-padded).
/// Panel by panel, tiles of 6 lags (12 vector sums in registers, a GEMM micro-kernel: A = the
/// residual's lag-shifted values, broadcast; B = the panel) run over the block's rows while the panel
/// (rows × 64 bytes) stays in the L1 cache; the lags after the last whole tile take a narrower tile.
DYNVAL_FMA_CLONES inline void lag_block_products(const double* DYNVAL_RESTRICT e, const double* DYNVAL_RESTRICT y,
                                                 Index panel_stride, Index rows, Index p, Index n_lags,
                                                 double* DYNVAL_RESTRICT acc) {
    constexpr int TL = 6;
    for (Index c0 = 0; c0 < p; c0 += lag_panel) {
        const double* panel = y + (c0 / lag_panel) * panel_stride * lag_panel;
        const Index width = std::min(lag_panel, p - c0);
        Index l0 = 0;
        for (; l0 + TL <= n_lags; l0 += TL) lag_panel_tile<TL>(e, panel, rows, l0, p, c0, width, acc);
        switch (n_lags - l0) {
            case 5: lag_panel_tile<5>(e, panel, rows, l0, p, c0, width, acc); break;
            case 4: lag_panel_tile<4>(e, panel, rows, l0, p, c0, width, acc); break;
            case 3: lag_panel_tile<3>(e, panel, rows, l0, p, c0, width, acc); break;
            case 2: lag_panel_tile<2>(e, panel, rows, l0, p, c0, width, acc); break;
            case 1: lag_panel_tile<1>(e, panel, rows, l0, p, c0, width, acc); break;
            default: break;
        }
    }
}

/// Row u of one joint's regressor columns `src` (p values), centred with the moments' shift and
/// deviation, into the panels of lag_block_products (padding columns are left as they are: zero).
DYNVAL_VECTOR_CLONES inline void pack_centred_row(const double* DYNVAL_RESTRICT src, Index p,
                                                  const double* DYNVAL_RESTRICT shift, const double* DYNVAL_RESTRICT dev,
                                                  Index panel_stride, Index u, double* DYNVAL_RESTRICT out) {
    Index c0 = 0;
#if defined(DYNVAL_VECTOR_TYPES)
    for (; c0 + lag_panel <= p; c0 += lag_panel) {  // whole panels, two vectors each
        double* dst = out + ((c0 / lag_panel) * panel_stride + u) * lag_panel;
        for (Index h = 0; h < lag_panel; h += 4) {
            vec4 v, sh, dv;
            load4(v, src + c0 + h);
            load4(sh, shift + c0 + h);
            load4(dv, dev + c0 + h);
            v = (v - sh) - dv;
            std::memcpy(dst + h, &v, sizeof v);
        }
    }
#endif
    for (; c0 < p; c0 += lag_panel) {
        double* dst = out + ((c0 / lag_panel) * panel_stride + u) * lag_panel;
        const Index width = std::min(lag_panel, p - c0);
        for (Index k = 0; k < width; ++k) dst[k] = (src[c0 + k] - shift[c0 + k]) - dev[c0 + k];
    }
}

/// pack_centred_row of the `count` columns `cols` of the row `src` (joint-relative indices), packed
/// side by side: column cols[k] goes to lane k; `shift` and `dev` are those columns' own, in the
/// same order. The same arithmetic per value as pack_centred_row.
inline void pack_centred_live(const double* DYNVAL_RESTRICT src, const Index* DYNVAL_RESTRICT cols, Index count,
                              const double* DYNVAL_RESTRICT shift, const double* DYNVAL_RESTRICT dev,
                              Index panel_stride, Index u, double* DYNVAL_RESTRICT out) {
    for (Index c0 = 0; c0 < count; c0 += lag_panel) {
        double* dst = out + ((c0 / lag_panel) * panel_stride + u) * lag_panel;
        const Index width = std::min(lag_panel, count - c0);
        for (Index k = 0; k < width; ++k) dst[k] = (src[cols[c0 + k]] - shift[c0 + k]) - dev[c0 + k];
    }
}

/// Moments of a large regressor as those of its two halves of rows, merged: one thread per half
/// when the machine has two. Whether to split depends on the size alone (at least 2^24 values),
/// so the result does not depend on the thread count.
template <class D>
joint_moments accumulate_signal_halves(const Eigen::MatrixBase<D>& x) {
    const Index n = x.rows(), cols = x.cols();
    const double values = static_cast<double>(n) * static_cast<double>(cols);
    if (values < 0x1p24 || n < 2) return accumulate_signal(x);
    const Index h = n / 2;
    joint_accumulator top(cols), bottom(cols);
    // About four operations per value (shift, two sums, the range) for the thread threshold.
    for_ranges(2, worker_count(2, 4.0 * values), [&](Index, Index first, Index last) {
        for (Index half = first; half < last; ++half) {
            if (half == 0) top.update_signal(x.topRows(h));
            else bottom.update_signal(x.bottomRows(n - h));
        }
    });
    top.merge(bottom);
    return top.result();
}

/// Σ_k ê_k·Ŷ_{k−ℓ,c} (ℓ = 0..max_lag, c < p) of every joint j with `use[j]`, products within
/// segments, for a regressor whose rows are contiguous (row stride `stride`, joint j's columns
/// from j·p): one (L+1, p) matrix per joint (empty where `use[j]` is false). `e` holds the centred
/// residuals as columns. The regressor is read once, a block of rows at a time, row by row for
/// every joint of a thread, each joint's columns centred with the moments' shift and deviation
/// into its panels (lag_block_products); partial sums go into compensated totals every `sum_rows`
/// rows. Only the columns that vary are packed and multiplied (a serial arm's regressor is zero in
/// most of its joint-column pairs, and a constant column's correlation is nan whatever its sums):
/// their sums come out 0. A column's sums do not depend on its place in the panels, so those of the
/// varying columns are the same bit for bit as when every column was multiplied.
inline std::vector<Eigen::MatrixXd> cross_lag_sums_rows(const Eigen::MatrixXd& e, const std::vector<bool>& use,
                                                        const double* y, Index stride, Index p, const joint_moments& my,
                                                        const std::vector<Index>& starts, Index n, Index max_lag) {
    // 128 rows: the packed panels of 7 joints × 70 columns (516 KB) stay in the L2 cache.
    constexpr Index block = 128, sum_rows = 1024;
    const Index m = e.cols(), n_lags = max_lag + 1;
    const auto lengths = segment_lengths(starts, n);
    std::vector<Index> joints;  // the joints to sum, split over threads (each joint's sums on one)
    // Per joint: its varying columns (`live`, joint-relative), their moments, and where its sums start.
    std::vector<std::vector<Index>> live(static_cast<std::size_t>(m));
    std::vector<std::vector<double>> shift(static_cast<std::size_t>(m)), dev(static_cast<std::size_t>(m));
    std::vector<std::size_t> at(static_cast<std::size_t>(m), 0);
    std::size_t sums_size = 0;
    Index live_total = 0;
    for (Index j = 0; j < m; ++j) {
        if (!use[static_cast<std::size_t>(j)]) continue;
        const auto sj = static_cast<std::size_t>(j);
        for (Index c = 0; c < p; ++c) {
            const Index q = j * p + c;
            if (my.tau_min(q) == my.tau_max(q)) continue;
            live[sj].push_back(c);
            shift[sj].push_back(my.tau_shift(q));
            dev[sj].push_back(my.tau_dev(q));
        }
        const auto pj = static_cast<Index>(live[sj].size());
        if (pj == 0) continue;
        joints.push_back(j);
        at[sj] = sums_size;
        sums_size += static_cast<std::size_t>(n_lags * pj);
        live_total += pj;
    }
    std::vector<double> acc(sums_size);
    std::vector<compensated> total(sums_size);
    // Each residual on its segment followed by max_lag zeros: lags never reach the next segment.
    Index padded_total = 0;
    std::vector<Index> seg_offset(starts.size());
    for (std::size_t s = 0; s < starts.size(); ++s) {
        seg_offset[s] = padded_total;
        padded_total += lengths[s] + max_lag;
    }
    std::vector<double> epad;
    if (!joints.empty()) {
        epad.assign(static_cast<std::size_t>(padded_total * m), 0.0);
        for (Index j : joints)
            for (std::size_t s = 0; s < starts.size(); ++s)
                std::copy(e.col(j).data() + starts[s], e.col(j).data() + starts[s] + lengths[s],
                          epad.begin() + j * padded_total + seg_offset[s]);
    }
    const Index n_joints = static_cast<Index>(joints.size());
    const double work = static_cast<double>(n) * static_cast<double>(n_lags) * static_cast<double>(live_total);
    detail::for_ranges(n_joints, detail::worker_count(n_joints, work), [&](Index, Index first, Index last) {
        // The block's packed rows of every joint of this range: the regressor is read row by row
        // (contiguous), not joint by joint (a strided read that ran at about 6 GB/s here).
        std::vector<Index> buf_at(static_cast<std::size_t>(last - first) + 1, 0);
        for (Index i = first; i < last; ++i) {
            const auto pj = static_cast<Index>(live[static_cast<std::size_t>(joints[static_cast<std::size_t>(i)])].size());
            buf_at[static_cast<std::size_t>(i - first + 1)] =
                buf_at[static_cast<std::size_t>(i - first)] + (pj + lag_panel - 1) / lag_panel * block * lag_panel;
        }
        std::vector<double> ybuf(static_cast<std::size_t>(buf_at.back()), 0.0);
        const auto flush = [&] {
            for (Index i = first; i < last; ++i) {
                const auto sj = static_cast<std::size_t>(joints[static_cast<std::size_t>(i)]);
                const std::size_t end = at[sj] + static_cast<std::size_t>(n_lags) * live[sj].size();
                for (std::size_t k = at[sj]; k < end; ++k) {
                    total[k].add(acc[k]);
                    acc[k] = 0.0;
                }
            }
        };
        for (std::size_t s = 0; s < starts.size(); ++s) {
            const Index s0 = starts[s], len = lengths[s];
            for (Index a = 0; a < len; a += block) {
                const Index rows = std::min(block, len - a);
                for (Index u = 0; u < rows; ++u)
                    for (Index i = first; i < last; ++i) {
                        const Index j = joints[static_cast<std::size_t>(i)];
                        const auto sj = static_cast<std::size_t>(j);
                        const auto pj = static_cast<Index>(live[sj].size());
                        double* out = ybuf.data() + buf_at[static_cast<std::size_t>(i - first)];
                        const double* src = y + (s0 + a + u) * stride + j * p;
                        if (pj == p)
                            pack_centred_row(src, p, shift[sj].data(), dev[sj].data(), block, u, out);
                        else
                            pack_centred_live(src, live[sj].data(), pj, shift[sj].data(), dev[sj].data(), block, u,
                                              out);
                    }
                for (Index i = first; i < last; ++i) {
                    const Index j = joints[static_cast<std::size_t>(i)];
                    const auto sj = static_cast<std::size_t>(j);
                    lag_block_products(epad.data() + j * padded_total + seg_offset[s] + a,
                                       ybuf.data() + buf_at[static_cast<std::size_t>(i - first)], block, rows,
                                       static_cast<Index>(live[sj].size()), n_lags, acc.data() + at[sj]);
                }
                if ((a + rows) % sum_rows == 0) flush();
            }
            flush();
        }
    });
    std::vector<Eigen::MatrixXd> sums(static_cast<std::size_t>(m));
    for (Index j = 0; j < m; ++j) {
        const auto sj = static_cast<std::size_t>(j);
        if (!use[sj]) continue;
        Eigen::MatrixXd& out = sums[sj];
        out.setZero(n_lags, p);
        const auto pj = static_cast<Index>(live[sj].size());
        for (Index l = 0; l < n_lags; ++l)
            for (Index k = 0; k < pj; ++k)
                out(l, live[sj][static_cast<std::size_t>(k)]) =
                    total[at[sj] + static_cast<std::size_t>(l * pj + k)].value();
    }
    return sums;
}

}  // namespace detail

/// ρ̂(ℓ), ℓ = 0..max_lag, per joint: shape (max_lag+1, m). `adjusted` divides lag ℓ by its
/// number of products (the lesson), otherwise by N (biased). A constant residual gives nan.
template <class D>
row_matrix autocorrelation(const Eigen::MatrixBase<D>& e, long long max_lag, bool adjusted = true,
                           const segment_spec& segments = {}) {
    const joint_moments mo = detail::checked_signal(e, "autocorrelation");
    const Index n = e.rows();
    const std::vector<Index> starts = segment_starts(segments, n);
    const Index lmax = detail::check_max_lag(max_lag, detail::longest(starts, n));
    const bool adj = adjusted;
    const Eigen::MatrixXd sums = detail::scaled_lag_sums(e, mo, starts, lmax);
    const auto lengths = segment_lengths(starts, n);
    row_matrix rho(lmax + 1, e.cols());
    const double nd = static_cast<double>(n);
    for (Index j = 0; j < e.cols(); ++j) {
        const bool constant = mo.tau_min(j) == mo.tau_max(j);
        const double r0 = sums(0, j) / nd;
        for (Index l = 0; l <= lmax; ++l) {
            const double d = adj && l > 0 ? static_cast<double>(lag_products(lengths, l)) : nd;
            rho(l, j) = constant ? std::numeric_limits<double>::quiet_NaN() : (sums(l, j) / d) / r0;
        }
    }
    return rho;
}

/// z/√n with z = Φ⁻¹((1 + level)/2): the white-noise band of ρ̂.
inline double confidence_band(long long n, double level = 0.95) {
    const long long nn = detail::require_int(n, "n", 1, -1, "an integer with n >= 1");
    if (!(level > 0.0 && level < 1.0)) detail::throw_parameter("level", "a number with 0 < level < 1", value_text(level));
    return normal_quantile(0.5 * (1.0 + level)) / std::sqrt(static_cast<double>(nn));
}

/// Ljung–Box or Box–Pierce statistics at each lag h of `lags`, per joint.
struct PortmanteauTest {
    portmanteau_test test = portmanteau_test::ljung_box;
    std::vector<long long> lags;
    long long model_df = 0;
    Eigen::ArrayXXd statistic, pvalue, log_pvalue;  ///< (n_lags, m)
    std::vector<long long> df;                      ///< lags − model_df
};

namespace detail {

struct portmanteau_parameters {
    long long max_lag = 0;
    long long model_df = 0;
    portmanteau_test test = portmanteau_test::ljung_box;
};

/// The parameter step of the portmanteau tests: lags (each in [1, limit)), model_df, test.
inline portmanteau_parameters check_portmanteau_parameters(const std::vector<long long>& lags, long long model_df,
                                                           portmanteau_test test, Index limit) {
    const std::string lag_req =
        "a positive integer or a non-empty sequence of positive integers less than " + std::to_string(limit);
    if (lags.empty()) throw_parameter("lags", lag_req, value_text(lags));
    long long min_lag = limit, max_lag = 0;
    for (long long h : lags) {
        if (h <= 0 || h >= limit) throw_parameter("lags", lag_req, value_text(lags));
        min_lag = std::min(min_lag, h);
        max_lag = std::max(max_lag, h);
    }
    portmanteau_parameters r;
    r.max_lag = max_lag;
    r.model_df =
        require_int(model_df, "model_df", 0, min_lag, "an integer with 0 <= model_df < " + std::to_string(min_lag));
    r.test = require_option(test, "test");
    return r;
}

/// Statistics from the biased lag sums S_ℓ (rows ℓ = 0..max lag, one column per joint) and the
/// product counts n_ℓ; `constant[j]` gives nan for joint j.
inline PortmanteauTest portmanteau_from_sums(const Eigen::MatrixXd& sums, const std::vector<Index>& n_products,
                                             double n, const std::vector<bool>& constant,
                                             const std::vector<long long>& lags, long long model_df,
                                             portmanteau_test which) {
    const Index max_lag = sums.rows() - 1, m = sums.cols();
    const Index n_lags = static_cast<Index>(lags.size());
    PortmanteauTest r;
    r.test = which;
    r.lags = lags;
    r.model_df = model_df;
    r.statistic.resize(n_lags, m);
    r.pvalue.resize(n_lags, m);
    r.log_pvalue.resize(n_lags, m);
    for (long long h : r.lags) r.df.push_back(h - model_df);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    for (Index j = 0; j < m; ++j) {
        const bool is_constant = constant[static_cast<std::size_t>(j)];
        // Cumulative Σ ρ̂_ℓ² (Box–Pierce) or Σ ρ̂_ℓ²/n_ℓ (Ljung–Box) for ℓ = 1..max_lag.
        std::vector<double> cumulative(static_cast<std::size_t>(max_lag + 1), 0.0);
        compensated acc;
        for (Index l = 1; l <= max_lag; ++l) {
            const double rho = sums(l, j) / sums(0, j);
            const double term = which == portmanteau_test::ljung_box
                                    ? rho * rho / static_cast<double>(n_products[static_cast<std::size_t>(l)])
                                    : rho * rho;
            acc.add(term);
            cumulative[static_cast<std::size_t>(l)] = acc.value();
        }
        for (Index i = 0; i < n_lags; ++i) {
            const auto h = static_cast<std::size_t>(r.lags[static_cast<std::size_t>(i)]);
            const double scale = which == portmanteau_test::ljung_box ? n * (n + 2.0) : n;
            const double q = is_constant ? nan : scale * cumulative[h];
            const double df = static_cast<double>(r.df[static_cast<std::size_t>(i)]);
            r.statistic(i, j) = q;
            r.pvalue(i, j) = is_constant ? nan : chi2_sf(q, df);
            r.log_pvalue(i, j) = is_constant ? nan : chi2_logsf(q, df);
        }
    }
    return r;
}

}  // namespace detail

/// Portmanteau test on the biased autocorrelation (contract §3.5).
template <class D>
PortmanteauTest portmanteau(const Eigen::MatrixBase<D>& e, const std::vector<long long>& lags, long long model_df,
                            const segment_spec& segments, portmanteau_test test) {
    const std::string function =
        option_traits<portmanteau_test>::valid(test) ? option_name(test) : std::string("portmanteau");
    const joint_moments mo = detail::checked_signal(e, function);
    const Index n = e.rows();
    const std::vector<Index> starts = segment_starts(segments, n);
    const Index limit = detail::longest(starts, n);
    const detail::portmanteau_parameters checked = detail::check_portmanteau_parameters(lags, model_df, test, limit);

    const Eigen::MatrixXd sums = detail::scaled_lag_sums(e, mo, starts, checked.max_lag);
    const auto lengths = segment_lengths(starts, n);
    std::vector<Index> n_products(static_cast<std::size_t>(checked.max_lag + 1));
    for (Index l = 0; l <= checked.max_lag; ++l) n_products[static_cast<std::size_t>(l)] = lag_products(lengths, l);
    std::vector<bool> constant(static_cast<std::size_t>(e.cols()));
    for (Index j = 0; j < e.cols(); ++j) constant[static_cast<std::size_t>(j)] = mo.tau_min(j) == mo.tau_max(j);
    return detail::portmanteau_from_sums(sums, n_products, static_cast<double>(n), constant, lags,
                                         checked.model_df, checked.test);
}

/// Ljung–Box Q(h) = N(N+2) Σ ρ̂²_ℓ / n_ℓ.
template <class D>
PortmanteauTest ljung_box(const Eigen::MatrixBase<D>& e, const std::vector<long long>& lags, long long model_df = 0,
                          const segment_spec& segments = {}) {
    return portmanteau(e, lags, model_df, segments, portmanteau_test::ljung_box);
}

/// Box–Pierce Q(h) = N Σ ρ̂²_ℓ.
template <class D>
PortmanteauTest box_pierce(const Eigen::MatrixBase<D>& e, const std::vector<long long>& lags, long long model_df = 0,
                           const segment_spec& segments = {}) {
    return portmanteau(e, lags, model_df, segments, portmanteau_test::box_pierce);
}

/// Cross-correlation of each joint's residual with that joint's regressor columns.
struct CrossCorrelation {
    Eigen::Index n_joints = 0, n_columns = 0, max_lag = 0;
    row_matrix rho;                       ///< (m·p, max_lag+1), row j·p + c
    std::vector<bool> constant_mask;      ///< (m·p): column c constant on joint j
    double band = 0.0;                    ///< z/√N (filled by the caller that knows `level`)
};

/// The moments of a regressor's columns that `cross_correlation` computes first (shift, spread,
/// range, the first non-finite value): they depend on the regressor alone, so a caller correlating
/// many residuals with one regressor computes them once and passes them to each call.
template <class DY>
joint_moments regressor_moments(const Eigen::MatrixBase<DY>& regressor) {
    return detail::accumulate_signal_halves(regressor);
}

/// ρ_{e_j Y_jc}(ℓ) = R̂_{eY}(ℓ) / √(R̂_e(0) R̂_Y(0)), with the regressor viewed as (N, m·p):
/// column j·p + c is joint j, column c (an (N, m, p) row-major array is exactly this view).
/// `given`: the regressor's `regressor_moments`, kept from an earlier call (the same values: a
/// different regressor is not detected beyond its shape); computed here when null.
template <class DE, class DY>
CrossCorrelation cross_correlation(const Eigen::MatrixBase<DE>& e, const Eigen::MatrixBase<DY>& regressor,
                                   long long n_columns, long long max_lag, bool adjusted = true,
                                   const segment_spec& segments = {}, const joint_moments* given = nullptr) {
    const Index n = e.rows(), m = e.cols();
    detail::check_columns(n, m, "e");
    if (regressor.cols() == 0)
        throw invalid_shape("regressor must have at least one column, got shape " +
                            shape_text(regressor.rows(), regressor.cols()));
    if (regressor.rows() != n)
        throw shape_mismatch("regressor must have shape (N, m, p) = (" + std::to_string(n) + ", " +
                             std::to_string(m) + ", p) to match e, got " +
                             shape_text(regressor.rows(), regressor.cols()));
    detail::check_min_samples(n, 2, "cross_correlation");
    joint_moments me = accumulate_signal(e);
    me.throw_if_nonfinite("e", "e");
    if (given && (given->n_samples != n || given->n_joints != regressor.cols()))
        throw shape_mismatch("the regressor's moments are of a " + shape_text(given->n_samples, given->n_joints) +
                             " regressor, not of this " + shape_text(regressor.rows(), regressor.cols()) + " one");
    const joint_moments my = given ? *given : detail::accumulate_signal_halves(regressor);
    const Index total = regressor.cols();
    // m·n_columns is formed with an overflow check: 2^62 + 1 columns on 4 joints must not wrap to 4.
    const auto product = detail::checked_mul(n_columns, m);
    const bool p_ok = n_columns > 0 && product && *product == total;
    if (my.nonfinite_meas) {
        const auto& hit = *my.nonfinite_meas;
        // The sample/joint/column wording needs a usable column count; otherwise row/column.
        if (p_ok) detail::throw_nonfinite_regressor(hit.row, hit.col, n_columns, hit.value);
        detail::throw_nonfinite("regressor", hit.row, hit.col, hit.value);
    }
    const std::vector<Index> starts = segment_starts(segments, n);
    if (!p_ok)
        detail::throw_parameter("n_columns", "a positive integer with m*n_columns = " + std::to_string(total),
                                value_text(n_columns));
    const Index p = n_columns;
    const Index lmax = detail::check_max_lag(max_lag, detail::longest(starts, n));
    const bool adj = adjusted;

    const auto lengths = segment_lengths(starts, n);
    const double nd = static_cast<double>(n);
    CrossCorrelation r;
    r.n_joints = m;
    r.n_columns = p;
    r.max_lag = lmax;
    r.rho.resize(m * p, lmax + 1);
    r.constant_mask.assign(static_cast<std::size_t>(m * p), false);
    Eigen::VectorXd ebuf, ybuf;
    std::vector<double> out;
    std::vector<double> denom(static_cast<std::size_t>(lmax + 1));
    for (Index l = 0; l <= lmax; ++l)
        denom[static_cast<std::size_t>(l)] = adj && l > 0 ? static_cast<double>(lag_products(lengths, l)) : nd;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    // Row-contiguous regressors (an (N, m, p) numpy array) take the register-tiled path for the
    // joints none of whose columns needs the power-of-two scaling of tiny data.
    const double* rows_data = nullptr;
    Index row_stride = 0;
    if constexpr ((int(DY::Flags) & Eigen::DirectAccessBit) && (int(DY::Flags) & Eigen::RowMajorBit)) {
        if (regressor.derived().innerStride() == 1) {
            rows_data = regressor.derived().data();
            row_stride = regressor.derived().outerStride();
        }
    }
    // The centred residuals and R_e(0) first, then the register-tiled sums of every joint none of
    // whose columns needs the power-of-two scaling of tiny data, in one read of the regressor.
    Eigen::MatrixXd ecent(n, m);
    std::vector<double> re0s(static_cast<std::size_t>(m));
    std::vector<bool> tiled(static_cast<std::size_t>(m), false);
    for (Index j = 0; j < m; ++j) {
        re0s[static_cast<std::size_t>(j)] = detail::centred_for_correlation(e, j, me, ebuf) / nd;
        ecent.col(j) = ebuf;
        bool ok = rows_data != nullptr && me.tau_min(j) != me.tau_max(j) && re0s[static_cast<std::size_t>(j)] > 0.0;
        for (Index c = 0; ok && c < p; ++c) {
            const Index q = j * p + c;  // constant columns are nan whatever their sums
            ok = my.tau_min(q) == my.tau_max(q) || !(my.tau_m2(q) < detail::tiny_sum_of_squares);
        }
        tiled[static_cast<std::size_t>(j)] = ok;
    }
    std::vector<Eigen::MatrixXd> tiled_sums;
    if (std::find(tiled.begin(), tiled.end(), true) != tiled.end())
        tiled_sums = detail::cross_lag_sums_rows(ecent, tiled, rows_data, row_stride, p, my, starts, n, lmax);
    for (Index j = 0; j < m; ++j) {
        const bool e_constant = me.tau_min(j) == me.tau_max(j);
        const double re0 = re0s[static_cast<std::size_t>(j)];
        const bool is_tiled = tiled[static_cast<std::size_t>(j)];
        if (!is_tiled) ebuf = ecent.col(j);
        for (Index c = 0; c < p; ++c) {
            const Index q = j * p + c;
            const bool y_constant = my.tau_min(q) == my.tau_max(q);
            r.constant_mask[static_cast<std::size_t>(q)] = y_constant;
            if (y_constant || e_constant) {
                r.rho.row(q).setConstant(nan);
                continue;
            }
            const double ry0 =
                (is_tiled ? my.tau_m2(q) : detail::centred_for_correlation(regressor, q, my, ybuf)) / nd;
            if (!(re0 > 0.0 && ry0 > 0.0)) {  // a spread that underflows even scaled: no scale to divide by
                r.rho.row(q).setConstant(nan);
                continue;
            }
            if (is_tiled) {
                const Eigen::MatrixXd& sums = tiled_sums[static_cast<std::size_t>(j)];
                out.assign(sums.col(c).data(), sums.col(c).data() + lmax + 1);
            } else {
                detail::lagged_sums(ebuf.data(), ybuf.data(), starts, n, lmax, out);
            }
            // Two roots, not the root of the product: R_e(0)·R_Y(0) overflows for data near 1e80
            // and underflows near 1e-80, both inside the accepted range.
            const double scale = 1.0 / (std::sqrt(re0) * std::sqrt(ry0));
            for (Index l = 0; l <= lmax; ++l) {
                const double d = denom[static_cast<std::size_t>(l)];
                // Cauchy-Schwarz bounds |rho(l)| by N/D_l (1 at lag 0 and without `adjusted`); the
                // rounding of the sums can step one ulp past it (contract §3.6).
                const double bound = nd / d;
                r.rho(q, l) = std::clamp(out[static_cast<std::size_t>(l)] / d * scale, -bound, bound);
            }
        }
    }
    return r;
}

}  // namespace dynval
