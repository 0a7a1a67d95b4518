// Tests of the streaming state (stream_state.hpp). The centred sums a state holds are compared with
// a direct long-double loop over the concatenated rows (two-pass overall means, segments by explicit
// membership), for one block, random chunkings (one-row chunks included), segment breaks and merge
// trees in any association order.
#include <dynval/dynval.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <random>
#include <vector>

namespace {

using Eigen::Index;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct Data {
    RowMatrix e, tau, y;  // (N, m), (N, m), (N, m·p)
};

Data make_data(Index n, Index m, Index p, unsigned seed, double offset) {
    std::mt19937_64 gen(seed);
    std::normal_distribution<double> normal;
    Data d{RowMatrix(n, m), RowMatrix(n, m), RowMatrix(n, m * p)};
    for (Index j = 0; j < m; ++j) {
        double ar = 0.0, walk = 0.0;
        for (Index t = 0; t < n; ++t) {
            ar = 0.7 * ar + normal(gen);
            walk += normal(gen) / 10.0;
            d.e(t, j) = offset + 0.3 * j + ar;
            d.tau(t, j) = offset * 3.0 + walk;
        }
    }
    for (Index t = 0; t < n; ++t)
        for (Index q = 0; q < m * p; ++q) d.y(t, q) = offset + 2.0 + 0.5 * d.e(t, q / p) + normal(gen);
    return d;
}

/// Centred sums from a state: Σ(x − x̄)(x' − x̄') over the pairs, as dynval.stream's `_moments`,
/// put back from the state's power-of-two units (2^exp per column) into the data's.
struct Moments {
    std::vector<double> cov_e, cov_ey, ss_y, tss, gram;
};

Moments moments(const dynval::stream_state& st) {
    const auto& l = st.layout();
    const std::size_t m = l.m, p = l.p, mp = m * p, le = l.acf_lags, lx = l.xcorr_lags;
    const double n = static_cast<double>(st.n);
    Moments mo;
    const auto cur = st.cur_e.values(), lag = st.lag_e.values(), prod = st.prod_e.values();
    std::vector<double> a(m);
    for (std::size_t j = 0; j < m; ++j) a[j] = cur[j] / n;
    for (std::size_t i = 0; i <= le; ++i)
        for (std::size_t j = 0; j < m; ++j) {
            const std::size_t k = i * m + j;
            mo.cov_e.push_back(std::ldexp(prod[k] - a[j] * (cur[k] + lag[k]) + static_cast<double>(st.pairs[i]) * a[j] * a[j],
                                          static_cast<int>(2 * st.exp_e[j])));
        }
    const auto st_sum = st.sum_t.values(), st_sq = st.sq_t.values();
    for (std::size_t j = 0; j < m; ++j)
        mo.tss.push_back(std::ldexp(st_sq[j] - st_sum[j] * st_sum[j] / n, static_cast<int>(2 * st.exp_t[j])));
    if (mp) {
        const auto ly = st.lag_y.values(), pey = st.prod_ey.values(), sq = st.sq_y.values();
        for (std::size_t i = 0; i <= lx; ++i)
            for (std::size_t q = 0; q < mp; ++q) {
                const std::size_t j = q / p, k = i * mp + q;
                const double b = ly[q] / n;
                mo.cov_ey.push_back(std::ldexp(pey[k] - b * cur[i * m + j] - a[j] * ly[k] +
                                                   static_cast<double>(st.pairs[i]) * a[j] * b,
                                               static_cast<int>(st.exp_e[j] + st.exp_y[q])));
            }
        for (std::size_t q = 0; q < mp; ++q)
            mo.ss_y.push_back(std::ldexp(sq[q] - ly[q] * ly[q] / n, static_cast<int>(2 * st.exp_y[q])));
    }
    if (l.gram) {
        const auto g = st.gram.values();
        for (std::size_t i = 0; i < m; ++i)
            for (std::size_t k = 0; k < m; ++k)
                mo.gram.push_back(std::ldexp(g[i * m + k] - cur[i] * cur[k] / n, static_cast<int>(st.exp_e[i] + st.exp_e[k])));
    }
    return mo;
}

/// The same sums by a direct loop over the rows with the given segment lengths.
Moments direct(const Data& d, const dynval::stream_layout& l, const std::vector<long long>& lengths) {
    const Index n = d.e.rows(), m = l.m, p = l.p, mp = m * p;
    std::vector<long double> me(m, 0), mt(m, 0), my(mp, 0);
    for (Index t = 0; t < n; ++t) {
        for (Index j = 0; j < m; ++j) {
            me[j] += d.e(t, j);
            mt[j] += d.tau(t, j);
        }
        for (Index q = 0; q < mp; ++q) my[q] += d.y(t, q);
    }
    for (auto& x : me) x /= n;
    for (auto& x : mt) x /= n;
    for (auto& x : my) x /= n;
    std::vector<long long> segment(n);
    {
        Index t = 0;
        for (std::size_t s = 0; s < lengths.size(); ++s)
            for (long long k = 0; k < lengths[s]; ++k) segment[t++] = static_cast<long long>(s);
    }
    Moments mo;
    for (Index i = 0; i <= l.acf_lags; ++i)
        for (Index j = 0; j < m; ++j) {
            long double s = 0;
            for (Index t = i; t < n; ++t)
                if (segment[t] == segment[t - i]) s += (d.e(t, j) - me[j]) * (d.e(t - i, j) - me[j]);
            mo.cov_e.push_back(static_cast<double>(s));
        }
    for (Index j = 0; j < m; ++j) {
        long double s = 0;
        for (Index t = 0; t < n; ++t) s += (d.tau(t, j) - mt[j]) * (d.tau(t, j) - mt[j]);
        mo.tss.push_back(static_cast<double>(s));
    }
    if (mp) {
        for (Index i = 0; i <= l.xcorr_lags; ++i)
            for (Index q = 0; q < mp; ++q) {
                long double s = 0;
                for (Index t = i; t < n; ++t)
                    if (segment[t] == segment[t - i]) s += (d.e(t, q / p) - me[q / p]) * (d.y(t - i, q) - my[q]);
                mo.cov_ey.push_back(static_cast<double>(s));
            }
        for (Index q = 0; q < mp; ++q) {
            long double s = 0;
            for (Index t = 0; t < n; ++t) s += (d.y(t, q) - my[q]) * (d.y(t, q) - my[q]);
            mo.ss_y.push_back(static_cast<double>(s));
        }
    }
    if (l.gram)
        for (Index i = 0; i < m; ++i)
            for (Index k = 0; k < m; ++k) {
                long double s = 0;
                for (Index t = 0; t < n; ++t) s += (d.e(t, i) - me[i]) * (d.e(t, k) - me[k]);
                mo.gram.push_back(static_cast<double>(s));
            }
    return mo;
}

/// Each pair agrees to 1e-14 of the natural size Σ(x − x̄)² (the lag-0 sums), as the Python tests ask.
void expect_close(const std::vector<double>& got, const std::vector<double>& want, double scale, const char* what) {
    ASSERT_EQ(got.size(), want.size()) << what;
    for (std::size_t i = 0; i < got.size(); ++i) EXPECT_NEAR(got[i], want[i], 1e-14 * scale) << what << " [" << i << "]";
}

void expect_moments(const dynval::stream_state& st, const Data& d, const std::vector<long long>& lengths) {
    ASSERT_EQ(st.lengths, lengths);
    ASSERT_EQ(st.n, d.e.rows());
    const auto got = moments(st), want = direct(d, st.layout(), lengths);
    double se = 0, sy = 0, stau = 0;
    for (Index j = 0; j < st.layout().m; ++j) se = std::max(se, want.cov_e[j]);
    for (double x : want.ss_y) sy = std::max(sy, x);
    for (double x : want.tss) stau = std::max(stau, x);
    expect_close(got.cov_e, want.cov_e, se, "cov_e");
    expect_close(got.tss, want.tss, stau, "tss");
    expect_close(got.cov_ey, want.cov_ey, std::sqrt(se * sy), "cov_ey");
    expect_close(got.ss_y, want.ss_y, sy, "ss_y");
    expect_close(got.gram, want.gram, se, "gram");
}

dynval::stream_state state_of(const Data& d, const dynval::stream_layout& l, Index a, Index b) {
    dynval::stream_state st(l);
    st.append(d.e.middleRows(a, b - a), d.tau.middleRows(a, b - a), d.y.middleRows(a, b - a));
    return st;
}

const dynval::stream_layout kLayout{3, 2, 17, 6, true};

TEST(StreamState, OneAppendEqualsDirectSums) {
    const auto d = make_data(5000, 3, 2, 1, 0.0);  // longer than block_rows(): internal merges
    expect_moments(state_of(d, kLayout, 0, 5000), d, {5000});
}

TEST(StreamState, LargeOffsetKeepsDigits) {
    const auto d = make_data(3000, 3, 2, 2, 1e5);
    expect_moments(state_of(d, kLayout, 0, 3000), d, {3000});
}

// The sums are held in units of a power of two per column (contract §4.1): data multiplied by 2^s
// give the same sums to the bit, with every exponent moved by s, at magnitudes whose squares
// underflow (2^-1000, about 1e-301) or whose cross products with a tiny column would.
TEST(StreamState, SumsDoNotDependOnTheScale) {
    const auto d = make_data(700, 3, 2, 7, 3.0);
    const auto chunked = [](const Data& x) {
        dynval::stream_state st(kLayout);
        for (auto [a, b] : {std::pair<Index, Index>{0, 1}, {1, 300}, {300, 301}, {301, 700}}) {
            dynval::stream_state part(kLayout);
            part.append(x.e.middleRows(a, b - a), x.tau.middleRows(a, b - a), x.y.middleRows(a, b - a));
            st.merge(part);
        }
        return st;
    };
    const auto base = chunked(d);
    for (int s : {-1000, -700, 400}) {
        const double f = std::ldexp(1.0, s);
        const Data scaled{d.e * f, d.tau * f, d.y * f};
        const auto st = chunked(scaled);
        for (std::size_t j = 0; j < 3; ++j) {
            EXPECT_EQ(st.exp_e[j], base.exp_e[j] + s);
            EXPECT_EQ(st.exp_t[j], base.exp_t[j] + s);
        }
        for (std::size_t q = 0; q < 6; ++q) EXPECT_EQ(st.exp_y[q], base.exp_y[q] + s);
        EXPECT_EQ(st.k_e, base.k_e);
        EXPECT_EQ(st.k_y, base.k_y);
        for (auto [x, y] : {std::pair{&st.prod_e, &base.prod_e}, {&st.cur_e, &base.cur_e}, {&st.lag_e, &base.lag_e},
                            {&st.gram, &base.gram}, {&st.sq_t, &base.sq_t}, {&st.sq_y, &base.sq_y},
                            {&st.prod_ey, &base.prod_ey}, {&st.lag_y, &base.lag_y}}) {
            EXPECT_EQ(x->hi, y->hi);
            EXPECT_EQ(x->lo, y->lo);
        }
    }
}

// A first block near 1e-250 and later ones near 1e100: the merge moves the first block's sums to
// the larger exponent, and the whole equals the direct sums.
TEST(StreamState, BlocksOfVeryDifferentMagnitudeMerge) {
    auto d = make_data(600, 3, 2, 8, 0.0);
    d.e.topRows(100) *= 1e-250;
    d.tau.topRows(100) *= 1e-250;
    d.y.topRows(100) *= 1e-250;
    d.e.bottomRows(500) *= 1e100;
    d.tau.bottomRows(500) *= 1e100;
    d.y.bottomRows(500) *= 1e100;
    auto st = state_of(d, kLayout, 0, 100);
    st.merge(state_of(d, kLayout, 100, 600));
    expect_moments(st, d, {600});
    for (std::size_t j = 0; j < 3; ++j) EXPECT_EQ(st.exp_e[j], std::ilogb(d.e.col(j).cwiseAbs().maxCoeff()) + 1);
}

TEST(StreamState, RandomChunkingsAndOneRowChunks) {
    const auto d = make_data(900, 3, 2, 3, 10.0);
    std::mt19937_64 gen(4);
    for (int trial = 0; trial < 5; ++trial) {
        dynval::stream_state st(kLayout);
        Index a = 0;
        while (a < 900) {
            const Index size = trial == 0 ? 1 : std::uniform_int_distribution<Index>(0, 40)(gen);
            const Index b = std::min<Index>(900, a + size);
            st.append(d.e.middleRows(a, b - a), d.tau.middleRows(a, b - a), d.y.middleRows(a, b - a));
            a = b;
        }
        expect_moments(st, d, {900});
    }
}

TEST(StreamState, BreaksEndSegments) {
    const auto d = make_data(600, 3, 2, 5, -3.0);
    dynval::stream_state st(kLayout);
    st.break_segment();  // before any row: no empty segment
    st.append(d.e.topRows(100), d.tau.topRows(100), d.y.topRows(100));
    st.break_segment();
    st.break_segment();
    st.append(d.e.middleRows(100, 5), d.tau.middleRows(100, 5), d.y.middleRows(100, 5));
    st.append(d.e.middleRows(105, 295), d.tau.middleRows(105, 295), d.y.middleRows(105, 295));
    st.break_segment();
    st.append(d.e.bottomRows(200), d.tau.bottomRows(200), d.y.bottomRows(200));
    expect_moments(st, d, {100, 300, 200});
}

TEST(StreamState, MergeTreesInAnyOrder) {
    const auto d = make_data(1200, 3, 2, 6, 50.0);
    std::mt19937_64 gen(7);
    for (int trial = 0; trial < 20; ++trial) {
        // Pieces (some shorter than the lags), some ending or starting with a break.
        std::vector<Index> cuts{0};
        while (cuts.back() < 1200)
            cuts.push_back(std::min<Index>(1200, cuts.back() + std::uniform_int_distribution<Index>(1, 300)(gen)));
        std::vector<dynval::stream_state> pieces;
        std::vector<long long> lengths;
        for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
            auto st = state_of(d, kLayout, cuts[i], cuts[i + 1]);
            const int how = std::uniform_int_distribution<int>(0, 3)(gen);
            const bool breaks = i > 0 && how < 2;
            if (breaks && how == 0) {
                dynval::stream_state front(kLayout);
                front.break_segment();
                front.merge(st);
                st = front;
            } else if (breaks) {
                pieces.back().break_segment();
            }
            if (lengths.empty() || breaks)
                lengths.push_back(cuts[i + 1] - cuts[i]);
            else
                lengths.back() += cuts[i + 1] - cuts[i];
            pieces.push_back(st);
        }
        std::function<dynval::stream_state(std::size_t, std::size_t)> tree = [&](std::size_t a, std::size_t b) {
            if (b - a == 1) return pieces[a];
            const auto split = std::uniform_int_distribution<std::size_t>(a + 1, b - 1)(gen);
            auto left = tree(a, split);
            left.merge(tree(split, b));
            return left;
        };
        expect_moments(tree(0, pieces.size()), d, lengths);
    }
}

TEST(StreamState, MergeWithEmptyAndShapeChecks) {
    const auto d = make_data(50, 3, 2, 8, 0.0);
    auto st = state_of(d, kLayout, 0, 50);
    st.merge(dynval::stream_state(kLayout));
    expect_moments(st, d, {50});
    dynval::stream_state empty(kLayout);
    empty.merge(st);
    expect_moments(empty, d, {50});
    EXPECT_THROW(st.merge(dynval::stream_state(dynval::stream_layout{3, 1, 17, 6, true})), dynval::input_error);
    EXPECT_THROW(st.append(d.e, d.tau), dynval::input_error);  // the layout has p = 2
    EXPECT_THROW(dynval::stream_state(dynval::stream_layout{3, 2, 4, 6, false}), dynval::input_error);
}

// append_measured forms e = meas − pred block by block; the state is the one `append` builds from
// the same e, bit for bit (same blocks, same order), with and without a regressor.
TEST(StreamState, AppendMeasuredIsAppendOfTheResidual) {
    const auto d = make_data(5000, 3, 2, 9, 4.0);
    const RowMatrix pred = d.tau - d.e;
    const RowMatrix meas = d.tau;
    std::mt19937_64 gen(10);
    for (const auto& layout : {kLayout, dynval::stream_layout{3, 0, 0, 0, false}, dynval::stream_layout{3, 0, 9, 0, true}}) {
        const bool has_y = layout.p > 0;
        dynval::stream_state by_e(layout), by_pair(layout);
        Index a = 0;
        while (a < 5000) {
            const Index b = std::min<Index>(5000, a + std::uniform_int_distribution<Index>(0, 3000)(gen));
            const RowMatrix e = meas.middleRows(a, b - a) - pred.middleRows(a, b - a);
            if (has_y)
                by_e.append(e, meas.middleRows(a, b - a), d.y.middleRows(a, b - a));
            else
                by_e.append(e, meas.middleRows(a, b - a));
            by_pair.append_measured(meas.middleRows(a, b - a), pred.middleRows(a, b - a), d.y.middleRows(a, b - a), has_y);
            a = b;
        }
        ASSERT_EQ(by_pair.n, 5000);
        EXPECT_EQ(by_pair.lengths, by_e.lengths);
        for (auto [x, y] : {std::pair{&by_pair.prod_e, &by_e.prod_e}, {&by_pair.cur_e, &by_e.cur_e},
                            {&by_pair.lag_e, &by_e.lag_e}, {&by_pair.gram, &by_e.gram}, {&by_pair.sum_t, &by_e.sum_t},
                            {&by_pair.sq_t, &by_e.sq_t}, {&by_pair.sq_y, &by_e.sq_y}, {&by_pair.prod_ey, &by_e.prod_ey},
                            {&by_pair.lag_y, &by_e.lag_y}}) {
            EXPECT_EQ(x->hi, y->hi);
            EXPECT_EQ(x->lo, y->lo);
        }
        EXPECT_EQ(by_pair.head_e, by_e.head_e);
        EXPECT_EQ(by_pair.tail_e, by_e.tail_e);
        EXPECT_EQ(by_pair.tail_y, by_e.tail_y);
        EXPECT_EQ(by_pair.min_e, by_e.min_e);
        EXPECT_EQ(by_pair.max_t, by_e.max_t);
        if (layout.p == 0) expect_moments(by_pair, Data{d.e, d.tau, RowMatrix(5000, 0)}, {5000});
    }
    dynval::stream_state st(kLayout);
    EXPECT_THROW(st.append_measured(meas, pred.leftCols(2), d.y, true), dynval::input_error);
    EXPECT_THROW(st.append_measured(meas, pred, d.y, false), dynval::input_error);  // the layout has p = 2
    EXPECT_EQ(st.n, 0);
}

// With enough work the blocks of a chunk are formed on several threads and merged in order: the
// state is the one-thread state bit for bit (DYNVAL_NUM_THREADS = 1, 2, 3, 8).
TEST(StreamState, ThreadedBlocksAreTheOneThreadState) {
    const dynval::stream_layout layout{4, 8, 60, 40, true};
    const auto d = make_data(64000, 4, 8, 11, 2.0);
    const RowMatrix pred = d.tau - d.e;
    const auto with_threads = [&](const char* count) {
        setenv("DYNVAL_NUM_THREADS", count, 1);
        dynval::stream_state st(layout);
        st.append_measured(d.tau.topRows(1000), pred.topRows(1000), d.y.topRows(1000), true);
        st.append_measured(d.tau.bottomRows(63000), pred.bottomRows(63000), d.y.bottomRows(63000), true);  // 31 blocks
        unsetenv("DYNVAL_NUM_THREADS");
        return st;
    };
    const double work = 63000.0 * 4 * (60 + 4 + 8 * 43);  // 1.03e8 multiply-adds
    setenv("DYNVAL_NUM_THREADS", "3", 1);
    const bool threaded = dynval::detail::worker_count(63000 / 2048 + 1, work) == 3;
    unsetenv("DYNVAL_NUM_THREADS");
    ASSERT_TRUE(threaded) << "the test's chunk is too small to be split";
    const auto one = with_threads("1");
    expect_moments(one, d, {64000});
    for (const char* count : {"2", "3", "8"}) {
        const auto many = with_threads(count);
        for (auto [x, y] : {std::pair{&many.prod_e, &one.prod_e}, {&many.cur_e, &one.cur_e}, {&many.lag_e, &one.lag_e},
                            {&many.gram, &one.gram}, {&many.sq_t, &one.sq_t}, {&many.prod_ey, &one.prod_ey},
                            {&many.lag_y, &one.lag_y}, {&many.sq_y, &one.sq_y}}) {
            EXPECT_EQ(x->hi, y->hi) << count << " threads";
            EXPECT_EQ(x->lo, y->lo) << count << " threads";
        }
        EXPECT_EQ(many.k_e, one.k_e);
        EXPECT_EQ(many.tail_y, one.tail_y);
        EXPECT_EQ(many.head_e, one.head_e);
    }
}

}  // namespace
