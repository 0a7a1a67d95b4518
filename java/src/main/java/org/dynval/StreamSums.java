package org.dynval;

import java.util.Arrays;

/**
 * The mergeable sums behind {@link ValidationAccumulator} (docs/contract.md §4.1, "State"): a run
 * of consecutive rows (one or more segments) summarised in a size that does not depend on the
 * number of rows. It follows the Python reference {@code dynval._stream.State} and the C++
 * {@code stream_state} step by step:
 *
 * <ul>
 *   <li>per joint, about a centre K that follows the running mean: Σ(τ − K) and Σ(τ − K)² of the
 *       target; for the residual e at every lag ℓ = 0..L the lagged products
 *       P_ℓ = Σ(e_t − K)(e_{t−ℓ} − K), the sums H_ℓ = Σ(e_t − K) and T_ℓ = Σ(e_{t−ℓ} − K) over
 *       the same pairs, and the pair count n_ℓ;
 *   <li>per regressor column, Σ(e_t − K_e)(Y_{t−ℓ} − K_Y), the lagged sums Σ(Y_{t−ℓ} − K_Y)
 *       (lag 0: Σ(Y − K_Y)) and Σ(Y − K_Y)²;
 *   <li>minima and maxima, because constancy is decided on the data (contract §3.2), and the
 *       m × m residual products for the {@code full} noise model;
 *   <li>the raw first L rows of the first segment and the last L rows of the last one: a later
 *       merge forms the lagged products that cross the junction from them;
 *   <li>the lengths of the first, last and longest segment and the number of segments.
 * </ul>
 *
 * <p>A new centre K' = K + δ needs only these sums:
 * Σ(x_t − K')(y_{t−ℓ} − K'') = P_ℓ − δ_y H_ℓ − δ_x T_ℓ + n_ℓ δ_x δ_y. A merge moves both operands
 * to their combined mean before adding them (Chan's pairwise update, extended to lagged products),
 * so every sum stays centred and an offset of 1e7 on the data costs no digits; running sums are
 * compensated, so many small blocks are as accurate as one.
 *
 * <p>As in the reference, every centre and sum is held in units of a power of two per column
 * (contract §4.1, "Scale"): {@code expE}, {@code expT} (m) and {@code expY} (m·p) are the exponents
 * k of the largest |x| seen in each column ({@link Kernels#scaleExponent}), and the sums are those
 * of x·2^-k, so no square underflows or overflows at any accepted magnitude. A block takes the
 * exponents of its own rows; a merge first moves both operands to the larger exponent of each column
 * (an exact multiplication by a power of two). Boundary rows, minima and maxima stay raw.
 *
 * <p>Arrays are flat and row-major: lag-major {@code (L+1, m)} for the residual,
 * {@code (L+1, m, p)} for the regressor, {@code (m, p)} per column, {@code (m, m)} for the products.
 * An instance always holds at least one row.
 */
final class StreamSums {
    final int m;
    final int p;
    final int lags;
    final boolean gram;

    long n;
    boolean startBreak; // the first row must not join the rows before it
    boolean endBreak; // the next row must not join the last row
    long segments;
    long firstLength;
    long lastLength;
    long longest;

    int[] expE; // power-of-two exponents per column: every centre and sum is in their units
    int[] expT;
    int[] expY;
    double[] kE;
    Compensated prodE;
    Compensated curE; // H_ℓ; H_0 = Σ(e − K)
    Compensated lagE; // T_ℓ
    long[] pairs;
    Compensated products; // (m, m) Σ(e_i − K_i)(e_k − K_k), full noise model only
    double[] minE;
    double[] maxE;

    double[] kT;
    Compensated sumT;
    Compensated sqT;
    double[] minT;
    double[] maxT;

    double[] kY;
    Compensated sqY;
    Compensated lagY;
    Compensated prodEY;
    double[] minY;
    double[] maxY;

    double[] headE; // (headRows, m) raw residual rows
    int headRows;
    double[] tailE; // (tailRows, m)
    double[] tailY; // (tailRows, m·p)
    int tailRows;

    /** A sum carried as hi + lo (Neumaier): lo keeps what each addition rounded away. */
    static final class Compensated {
        final double[] hi;
        final double[] lo;

        Compensated(int size) {
            hi = new double[size];
            lo = new double[size];
        }

        private Compensated(double[] hi, double[] lo) {
            this.hi = hi;
            this.lo = lo;
        }

        void add(int i, double x) {
            double s = hi[i] + x;
            double b = s - hi[i];
            lo[i] += (hi[i] - (s - b)) + (x - b);
            hi[i] = s;
        }

        void addSum(Compensated other) {
            for (int i = 0; i < hi.length; i++) {
                add(i, other.hi[i]);
                lo[i] += other.lo[i];
            }
        }

        double value(int i) {
            return hi[i] + lo[i];
        }

        /** Multiplies element i by 2^k (exact unless a part underflows). */
        void scale(int i, int k) {
            hi[i] = Math.scalb(hi[i], k);
            lo[i] = Math.scalb(lo[i], k);
        }

        double[] values() {
            double[] out = new double[hi.length];
            for (int i = 0; i < out.length; i++) {
                out[i] = hi[i] + lo[i];
            }
            return out;
        }

        Compensated copy() {
            return new Compensated(hi.clone(), lo.clone());
        }

        int size() {
            return hi.length;
        }
    }

    private StreamSums(int m, int p, int lags, boolean gram) {
        this.m = m;
        this.p = p;
        this.lags = lags;
        this.gram = gram;
        int mp = m * p;
        expE = new int[m];
        expT = new int[m];
        expY = new int[mp];
        kE = new double[m];
        prodE = new Compensated((lags + 1) * m);
        curE = new Compensated((lags + 1) * m);
        lagE = new Compensated((lags + 1) * m);
        pairs = new long[lags + 1];
        products = new Compensated(gram ? m * m : 0);
        minE = new double[m];
        maxE = new double[m];
        kT = new double[m];
        sumT = new Compensated(m);
        sqT = new Compensated(m);
        minT = new double[m];
        maxT = new double[m];
        kY = new double[mp];
        sqY = new Compensated(mp);
        lagY = new Compensated((lags + 1) * mp);
        prodEY = new Compensated((lags + 1) * mp);
        minY = new double[mp];
        maxY = new double[mp];
        headE = new double[lags * m];
        tailE = new double[lags * m];
        tailY = new double[lags * mp];
    }

    /** An independent copy. */
    StreamSums copy() {
        StreamSums c = new StreamSums(m, p, lags, gram);
        c.n = n;
        c.startBreak = startBreak;
        c.endBreak = endBreak;
        c.segments = segments;
        c.firstLength = firstLength;
        c.lastLength = lastLength;
        c.longest = longest;
        c.expE = expE.clone();
        c.expT = expT.clone();
        c.expY = expY.clone();
        c.kE = kE.clone();
        c.prodE = prodE.copy();
        c.curE = curE.copy();
        c.lagE = lagE.copy();
        c.pairs = pairs.clone();
        c.products = products.copy();
        c.minE = minE.clone();
        c.maxE = maxE.clone();
        c.kT = kT.clone();
        c.sumT = sumT.copy();
        c.sqT = sqT.copy();
        c.minT = minT.clone();
        c.maxT = maxT.clone();
        c.kY = kY.clone();
        c.sqY = sqY.copy();
        c.lagY = lagY.copy();
        c.prodEY = prodEY.copy();
        c.minY = minY.clone();
        c.maxY = maxY.clone();
        c.headE = headE.clone();
        c.headRows = headRows;
        c.tailE = tailE.clone();
        c.tailY = tailY.clone();
        c.tailRows = tailRows;
        return c;
    }

    /** Numbers held (doubles and counts): fixed by m, p and the lags, whatever the rows seen. */
    long retainedValues() {
        long total = 0;
        for (Compensated c : new Compensated[] {prodE, curE, lagE, products, sumT, sqT, sqY, lagY, prodEY}) {
            total += 2L * c.size();
        }
        for (double[] a : new double[][] {kE, minE, maxE, kT, minT, maxT, kY, minY, maxY, headE, tailE, tailY}) {
            total += a.length;
        }
        return total + pairs.length + expE.length + expT.length + expY.length;
    }

    // ------------------------------------------------------------------ one block

    /**
     * The sums of one segment of {@code c >= 1} rows: residual {@code e} and target {@code tau}
     * row-major (c, m), regressor {@code y} row-major (c, m·p) when p > 0.
     */
    static StreamSums fromBlock(int m, int p, int lags, boolean gram, double[] e, double[] tau, double[] y, int c) {
        StreamSums st = new StreamSums(m, p, lags, gram);
        int mp = m * p;
        st.n = c;
        st.segments = 1;
        st.firstLength = c;
        st.lastLength = c;
        st.longest = c;
        // Joint-major centred copies: each lagged product is then a run of contiguous values.
        double[][] xe = centredColumns(e, c, m, st.kE, st.minE, st.maxE, st.expE);
        int top = Math.min(lags, c - 1);
        for (int j = 0; j < m; j++) {
            for (int l = 0; l <= top; l++) {
                st.prodE.hi[l * m + j] = dot(xe[j], l, xe[j], 0, c - l);
            }
        }
        boundarySums(xe, lags, st.curE.hi, st.lagE.hi);
        for (int l = 0; l <= lags; l++) {
            st.pairs[l] = Math.max(c - l, 0);
        }
        if (gram) {
            for (int i = 0; i < m; i++) {
                for (int k = i; k < m; k++) {
                    double g = dot(xe[i], 0, xe[k], 0, c);
                    st.products.hi[i * m + k] = g;
                    st.products.hi[k * m + i] = g;
                }
            }
        }
        double[][] xt = centredColumns(tau, c, m, st.kT, st.minT, st.maxT, st.expT);
        for (int j = 0; j < m; j++) {
            st.sumT.hi[j] = Kernels.sum(xt[j]);
            st.sqT.hi[j] = dot(xt[j], 0, xt[j], 0, c);
        }
        if (mp > 0) {
            double[][] xy = centredColumns(y, c, mp, st.kY, st.minY, st.maxY, st.expY); // row j·p + col
            for (int q = 0; q < mp; q++) {
                st.sqY.hi[q] = dot(xy[q], 0, xy[q], 0, c);
            }
            boundarySums(xy, lags, null, st.lagY.hi);
            for (int j = 0; j < m; j++) {
                for (int col = 0; col < p; col++) {
                    int q = j * p + col;
                    for (int l = 0; l <= top; l++) {
                        st.prodEY.hi[l * mp + q] = dot(xe[j], l, xy[q], 0, c - l);
                    }
                }
            }
        }
        int kept = Math.min(lags, c);
        st.headRows = kept;
        st.tailRows = kept;
        System.arraycopy(e, 0, st.headE, 0, kept * m);
        System.arraycopy(e, (c - kept) * m, st.tailE, 0, kept * m);
        if (mp > 0) {
            System.arraycopy(y, (c - kept) * mp, st.tailY, 0, kept * mp);
        }
        return st;
    }

    /**
     * The columns of row-major {@code x} (c, k), each scaled by 2^-e (e its exponent) and centred on
     * its mean; writes the centres (scaled), the raw extremes and the exponents.
     */
    private static double[][] centredColumns(double[] x, int c, int k, double[] centre, double[] lo, double[] hi,
            int[] exps) {
        double[][] out = new double[k][c];
        for (int t = 0; t < c; t++) {
            int base = t * k;
            for (int j = 0; j < k; j++) {
                out[j][t] = x[base + j];
            }
        }
        for (int j = 0; j < k; j++) {
            double[] col = out[j];
            double mn = Double.POSITIVE_INFINITY;
            double mx = Double.NEGATIVE_INFINITY;
            for (double v : col) {
                mn = Math.min(mn, v);
                mx = Math.max(mx, v);
            }
            lo[j] = mn;
            hi[j] = mx;
            exps[j] = Kernels.scaleExponent(new double[] {mn, mx});
            for (int t = 0; t < c; t++) {
                col[t] = Math.scalb(col[t], -exps[j]);
            }
            centre[j] = Kernels.sum(col) / c;
            for (int t = 0; t < c; t++) {
                col[t] -= centre[j];
            }
        }
        return out;
    }

    /** Σ a[ia + i]·b[ib + i], i < count, compensated as the in-memory lagged products are. */
    private static double dot(double[] a, int ia, double[] b, int ib, int count) {
        double s = 0.0;
        double comp = 0.0;
        for (int i = 0; i < count; i++) {
            double v = a[ia + i] * b[ib + i];
            double t = s + v;
            comp += Math.abs(s) >= Math.abs(v) ? (s - t) + v : (v - t) + s;
            s = t;
        }
        return s + comp;
    }

    /**
     * For centred columns x (k, c) of one segment: Σ x_t over the current elements (t ≥ ℓ) and
     * over the lagged elements (t < c − ℓ) of the lag-ℓ pairs, ℓ = 0..lags, lag-major (lags+1, k);
     * 0 where a lag has no pair. {@code cur} may be null.
     */
    private static void boundarySums(double[][] x, int lags, double[] cur, double[] lag) {
        int k = x.length;
        for (int r = 0; r < k; r++) {
            double[] row = x[r];
            int c = row.length;
            int top = Math.min(lags, c - 1);
            double total = Kernels.sum(row);
            if (cur != null) {
                cur[r] = total;
            }
            lag[r] = total;
            double head = 0.0;
            double tail = 0.0;
            for (int l = 1; l <= top; l++) {
                head += row[l - 1];
                tail += row[c - l];
                if (cur != null) {
                    cur[l * k + r] = total - head;
                }
                lag[l * k + r] = total - tail;
            }
        }
    }

    // ------------------------------------------------------------------ centres

    double meanE(int j) {
        return kE[j] + curE.value(j) / n;
    }

    double meanT(int j) {
        return kT[j] + sumT.value(j) / n;
    }

    double meanY(int q) {
        return kY[q] + lagY.value(q) / n;
    }

    /** Moves every sum to new centres (x − K' = (x − K) − δ), each correction from the sums before any moves. */
    private void recentre(double[] ke, double[] kt, double[] ky) {
        int mp = m * p;
        double nn = n;
        double[] d = new double[m];
        double[] cur = curE.values();
        double[] lag = lagE.values();
        for (int j = 0; j < m; j++) {
            d[j] = ke[j] - kE[j];
        }
        if (gram) {
            for (int i = 0; i < m; i++) {
                for (int k = 0; k < m; k++) {
                    products.add(i * m + k, -(d[i] * cur[k] + cur[i] * d[k]) + nn * (d[i] * d[k]));
                }
            }
        }
        if (mp > 0) {
            double[] dy = new double[mp];
            double[] ly = lagY.values();
            for (int q = 0; q < mp; q++) {
                dy[q] = ky[q] - kY[q];
            }
            for (int l = 0; l <= lags; l++) {
                double nl = pairs[l];
                for (int j = 0; j < m; j++) {
                    for (int col = 0; col < p; col++) {
                        int q = j * p + col;
                        int i = l * mp + q;
                        prodEY.add(i, -dy[q] * cur[l * m + j] - d[j] * ly[i] + nl * d[j] * dy[q]);
                    }
                }
            }
            for (int q = 0; q < mp; q++) {
                sqY.add(q, -2.0 * dy[q] * ly[q] + nn * dy[q] * dy[q]);
            }
            for (int l = 0; l <= lags; l++) {
                double nl = pairs[l];
                for (int q = 0; q < mp; q++) {
                    lagY.add(l * mp + q, -nl * dy[q]);
                }
            }
            kY = ky.clone();
        }
        for (int l = 0; l <= lags; l++) {
            double nl = pairs[l];
            for (int j = 0; j < m; j++) {
                int i = l * m + j;
                prodE.add(i, -d[j] * (cur[i] + lag[i]) + nl * d[j] * d[j]);
                curE.add(i, -nl * d[j]);
                lagE.add(i, -nl * d[j]);
            }
        }
        kE = ke.clone();
        double[] st = sumT.values();
        for (int j = 0; j < m; j++) {
            double dt = kt[j] - kT[j];
            sqT.add(j, -2.0 * dt * st[j] + nn * dt * dt);
            sumT.add(j, -nn * dt);
        }
        kT = kt.clone();
    }

    /**
     * Moves every centre and sum to the exponents given (each at least the state's own): a sum of
     * products of columns a and b is multiplied by 2^-(da + db), a sum or centre by 2^-da.
     */
    private void rescale(int[] ee, int[] et, int[] ey) {
        int mp = m * p;
        for (int j = 0; j < m; j++) {
            int de = ee[j] - expE[j];
            int dt = et[j] - expT[j];
            if (de != 0) {
                kE[j] = Math.scalb(kE[j], -de);
                for (int l = 0; l <= lags; l++) {
                    prodE.scale(l * m + j, -2 * de);
                    curE.scale(l * m + j, -de);
                    lagE.scale(l * m + j, -de);
                }
                if (gram) {
                    for (int k = 0; k < m; k++) {
                        products.scale(j * m + k, -de); // row j and column j: (j, j) twice
                        products.scale(k * m + j, -de);
                    }
                }
            }
            if (dt != 0) {
                kT[j] = Math.scalb(kT[j], -dt);
                sumT.scale(j, -dt);
                sqT.scale(j, -2 * dt);
            }
        }
        for (int q = 0; q < mp; q++) {
            int dy = ey[q] - expY[q];
            int dq = ee[q / p] - expE[q / p] + dy;
            if (dy != 0) {
                kY[q] = Math.scalb(kY[q], -dy);
                sqY.scale(q, -2 * dy);
            }
            for (int l = 0; l <= lags; l++) {
                if (dy != 0) {
                    lagY.scale(l * mp + q, -dy);
                }
                if (dq != 0) {
                    prodEY.scale(l * mp + q, -dq);
                }
            }
        }
        expE = ee.clone();
        expT = et.clone();
        expY = ey.clone();
    }

    private static int[] larger(int[] a, int[] b) {
        int[] out = new int[a.length];
        for (int i = 0; i < a.length; i++) {
            out[i] = Math.max(a[i], b[i]);
        }
        return out;
    }

    // ------------------------------------------------------------------ merge

    /**
     * Adds {@code b}, whose rows follow this state's, consuming it (callers pass a copy when they
     * keep it). Lags join across the junction unless this state ends, or {@code b} starts, with a break.
     */
    void mergeOwned(StreamSums b) {
        int mp = m * p;
        // both operands in the units of the larger exponent of each column
        int[] ee = larger(expE, b.expE);
        int[] et = larger(expT, b.expT);
        int[] ey = larger(expY, b.expY);
        rescale(ee, et, ey);
        b.rescale(ee, et, ey);
        double w = (double) b.n / (double) (n + b.n);
        double[] ke = new double[m];
        double[] kt = new double[m];
        double[] ky = new double[mp];
        for (int j = 0; j < m; j++) {
            double ma = meanE(j);
            double ta = meanT(j);
            ke[j] = ma + w * (b.meanE(j) - ma);
            kt[j] = ta + w * (b.meanT(j) - ta);
        }
        for (int q = 0; q < mp; q++) {
            double ya = meanY(q);
            ky[q] = ya + w * (b.meanY(q) - ya);
        }
        recentre(ke, kt, ky);
        b.recentre(ke, kt, ky);
        boolean join = !(endBreak || b.startBreak);
        if (join) {
            addJunction(b);
        }
        addSums(b);
        joinBoundaries(b, join);
    }

    private void addSums(StreamSums b) {
        prodE.addSum(b.prodE);
        curE.addSum(b.curE);
        lagE.addSum(b.lagE);
        products.addSum(b.products);
        sumT.addSum(b.sumT);
        sqT.addSum(b.sqT);
        sqY.addSum(b.sqY);
        lagY.addSum(b.lagY);
        prodEY.addSum(b.prodEY);
        for (int l = 0; l <= lags; l++) {
            pairs[l] += b.pairs[l];
        }
        n += b.n;
        extremes(minE, maxE, b.minE, b.maxE);
        extremes(minT, maxT, b.minT, b.maxT);
        extremes(minY, maxY, b.minY, b.maxY);
    }

    private static void extremes(double[] lo, double[] hi, double[] blo, double[] bhi) {
        for (int i = 0; i < lo.length; i++) {
            lo[i] = Math.min(lo[i], blo[i]);
            hi[i] = Math.max(hi[i], bhi[i]);
        }
    }

    /**
     * The lagged products whose current element is among b's first rows and whose lagged element
     * is among this state's last rows (both already on the same centres).
     */
    private void addJunction(StreamSums b) {
        int mp = m * p;
        double[] prod = new double[m];
        double[] cur = new double[m];
        double[] lag = new double[m];
        double[] py = new double[mp];
        double[] sy = new double[mp];
        for (int l = 1; l <= lags; l++) {
            // head row i pairs with tail row tailRows − l + i, which must exist
            int i0 = Math.max(0, l - tailRows);
            int i1 = Math.min(l, b.headRows);
            if (i0 >= i1) {
                continue;
            }
            Arrays.fill(prod, 0.0);
            Arrays.fill(cur, 0.0);
            Arrays.fill(lag, 0.0);
            Arrays.fill(py, 0.0);
            Arrays.fill(sy, 0.0);
            for (int i = i0; i < i1; i++) {
                int t = tailRows - l + i;
                for (int j = 0; j < m; j++) {
                    double h = Math.scalb(b.headE[i * m + j], -expE[j]) - kE[j];
                    double g = Math.scalb(tailE[t * m + j], -expE[j]) - kE[j];
                    prod[j] += h * g;
                    cur[j] += h;
                    lag[j] += g;
                    for (int col = 0; col < p; col++) {
                        int q = j * p + col;
                        double gy = Math.scalb(tailY[t * mp + q], -expY[q]) - kY[q];
                        py[q] += h * gy;
                        sy[q] += gy;
                    }
                }
            }
            for (int j = 0; j < m; j++) {
                prodE.add(l * m + j, prod[j]);
                curE.add(l * m + j, cur[j]);
                lagE.add(l * m + j, lag[j]);
            }
            for (int q = 0; q < mp; q++) {
                prodEY.add(l * mp + q, py[q]);
                lagY.add(l * mp + q, sy[q]);
            }
            pairs[l] += i1 - i0;
        }
    }

    /** Segment summary and boundary rows of the concatenation. */
    private void joinBoundaries(StreamSums b, boolean join) {
        int mp = m * p;
        boolean singleA = segments == 1;
        boolean singleB = b.segments == 1;
        if (join && singleA && headRows < lags) {
            int extra = Math.min(lags - headRows, b.headRows);
            System.arraycopy(b.headE, 0, headE, headRows * m, extra * m);
            headRows += extra;
        }
        if (join && singleB) {
            // the last rows of a's tail followed by b's whole tail, at most `lags` in all
            int fromA = Math.min(tailRows, lags - b.tailRows);
            int start = tailRows - fromA;
            System.arraycopy(tailE, start * m, tailE, 0, fromA * m);
            System.arraycopy(b.tailE, 0, tailE, fromA * m, b.tailRows * m);
            System.arraycopy(tailY, start * mp, tailY, 0, fromA * mp);
            System.arraycopy(b.tailY, 0, tailY, fromA * mp, b.tailRows * mp);
            tailRows = fromA + b.tailRows;
        } else {
            System.arraycopy(b.tailE, 0, tailE, 0, b.tailRows * m);
            System.arraycopy(b.tailY, 0, tailY, 0, b.tailRows * mp);
            tailRows = b.tailRows;
        }
        if (join) {
            long joined = lastLength + b.firstLength;
            longest = Math.max(Math.max(longest, b.longest), joined);
            if (singleA) {
                firstLength = joined;
            }
            lastLength = singleB ? joined : b.lastLength;
            segments += b.segments - 1;
        } else {
            longest = Math.max(longest, b.longest);
            lastLength = b.lastLength;
            segments += b.segments;
        }
        endBreak = b.endBreak;
    }
}
