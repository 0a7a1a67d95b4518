package org.dynval;

/**
 * The numerical kernels, on joint-major columns (one {@code double[]} per joint) that have
 * passed every check. Sums are compensated (Neumaier) and centred sums use the corrected
 * two-pass algorithm, so data riding on a large offset (1e7 + noise) keep their precision:
 * E[x²] − E[x]² would lose it.
 */
final class Kernels {
    private Kernels() {
    }

    /** Σx with Neumaier's compensation. */
    static double sum(double[] x) {
        double s = 0.0;
        double c = 0.0;
        for (double v : x) {
            double t = s + v;
            c += Math.abs(s) >= Math.abs(v) ? (s - t) + v : (v - t) + s;
            s = t;
        }
        return s + c;
    }

    /** Σx² (compensated; no cancellation to guard against, the compensation is for long sums). */
    static double sumSquares(double[] x) {
        double s = 0.0;
        double c = 0.0;
        for (double v : x) {
            double sq = v * v;
            double t = s + sq;
            c += s >= sq ? (s - t) + sq : (sq - t) + s;
            s = t;
        }
        return s + c;
    }

    /**
     * Exponent k with max|x|·2^-k in [0.5, 1), 0 for an all-zero series (contract §1.3): x·2^-k
     * squares without underflow or overflow, and the scaling is exact.
     */
    static int scaleExponent(double[] x) {
        double big = 0.0;
        for (double v : x) {
            big = Math.max(big, Math.abs(v));
        }
        if (big == 0.0) {
            return 0;
        }
        // getExponent is −1023 for every subnormal: measure those after an exact shift.
        return big >= Double.MIN_NORMAL ? Math.getExponent(big) + 1 : Math.getExponent(Math.scalb(big, 64)) + 1 - 64;
    }

    /** x·2^-k (exact: one rounding-free scalb per value). */
    static double[] scaled(double[] x, int k) {
        double[] out = new double[x.length];
        for (int i = 0; i < x.length; i++) {
            out[i] = Math.scalb(x[i], -k);
        }
        return out;
    }

    /** A sum of squares carried as {@code s}·4^k, so that it keeps its digits for tiny data. */
    record ScaledSum(double s, int k) {
        double value() {
            return Math.scalb(s, 2 * k);
        }

        /** √(s/d)·2^k: a root mean square scaled back after the root. */
        double rootMean(double d) {
            return Math.scalb(Math.sqrt(s / d), k);
        }

        /** ln(s·4^k / d) without forming s·4^k. */
        double logMean(double d) {
            return Math.log(s / d) + 2.0 * k * Math.log(2.0);
        }

        /** a / b, exact in the exponents (IEEE ±inf and nan for b = 0). */
        static double ratio(ScaledSum a, ScaledSum b) {
            return Math.scalb(a.s() / b.s(), 2 * (a.k() - b.k()));
        }
    }

    /** Σx² of x scaled by a power of two near its largest |x|. */
    static ScaledSum scaledSumSquares(double[] x) {
        int k = scaleExponent(x);
        return new ScaledSum(sumSquares(scaled(x, k)), k);
    }

    /** Mean (in the data's units) and centred sum of squares (scaled) of one series. */
    record ScaledMoments(double mean, ScaledSum ss, boolean constant) {
    }

    static ScaledMoments scaledMoments(double[] x) {
        int k = scaleExponent(x);
        Moments mo = moments(scaled(x, k));
        return new ScaledMoments(Math.scalb(mo.mean(), k), new ScaledSum(mo.ss(), k), mo.constant());
    }

    /** Min equals max: decided on the data, not on a rounded sum of squares (contract §3.2). */
    static boolean isConstant(double[] x) {
        double lo = x[0];
        double hi = x[0];
        for (double v : x) {
            lo = Math.min(lo, v);
            hi = Math.max(hi, v);
        }
        return lo == hi;
    }

    /** Mean, centred sum of squares and constancy of one series. */
    record Moments(double mean, double ss, boolean constant) {
    }

    /**
     * Corrected two-pass moments: with d = x − fl(x̄), the mean is fl(x̄) + Σd/n and the centred
     * sum of squares Σd² − (Σd)²/n; Σd measures the rounding of the first mean to full precision.
     */
    static Moments moments(double[] x) {
        int n = x.length;
        boolean constant = isConstant(x);
        double first = sum(x) / n;
        double[] d = new double[n];
        for (int k = 0; k < n; k++) {
            d[k] = x[k] - first;
        }
        double shift = sum(d);
        double ss = Math.max(sumSquares(d) - shift * shift / n, 0.0);
        if (constant) {
            ss = 0.0;
        }
        return new Moments(first + shift / n, ss, constant);
    }

    /** x − x̄ with the rounding of the mean removed by a second pass. */
    static double[] centred(double[] x) {
        int n = x.length;
        double mean = sum(x) / n;
        double[] d = new double[n];
        for (int k = 0; k < n; k++) {
            d[k] = x[k] - mean;
        }
        double correction = sum(d) / n;
        for (int k = 0; k < n; k++) {
            d[k] -= correction;
        }
        return d;
    }

    /** S[ℓ] = Σ over segments Σ_k x[k]·y[k − ℓ], ℓ = 0..maxLag; only pairs inside one segment. */
    static double[] laggedProducts(double[] x, double[] y, int maxLag, int[] starts) {
        int n = x.length;
        double[] out = new double[maxLag + 1];
        for (int lag = 0; lag <= maxLag; lag++) {
            double s = 0.0;
            double c = 0.0;
            for (int seg = 0; seg < starts.length; seg++) {
                int a = starts[seg];
                int b = seg + 1 < starts.length ? starts[seg + 1] : n;
                for (int k = a + lag; k < b; k++) {
                    double v = x[k] * y[k - lag];
                    double t = s + v;
                    c += Math.abs(s) >= Math.abs(v) ? (s - t) + v : (v - t) + s;
                    s = t;
                }
            }
            out[lag] = s + c;
        }
        return out;
    }

    /** D_ℓ: the number of products n_ℓ when adjusted (D_0 = N either way), N otherwise. */
    static double[] denominators(int[] starts, int n, int maxLag, boolean adjusted) {
        double[] out = new double[maxLag + 1];
        for (int lag = 0; lag <= maxLag; lag++) {
            out[lag] = adjusted ? (double) Segments.productCount(starts, n, lag) : (double) n;
        }
        return out;
    }

    /** A centred series with its Σd² (0 for a constant series). */
    record Centred(double[] d, double ss, boolean constant) {
    }

    /** Centred (and scaled by a power of two: correlations do not depend on the scale) series. */
    static Centred centredAndSs(double[] raw) {
        double[] x = scaled(raw, scaleExponent(raw));
        boolean constant = isConstant(x);
        double[] d = centred(x);
        double ss = constant ? 0.0 : sumSquares(d);
        return new Centred(d, ss, constant);
    }

    /** ρ̂(ℓ) of one joint, ℓ = 0..maxLag; nan throughout for a constant series. */
    static double[] autocorrelation(double[] x, int maxLag, boolean adjusted, int[] starts) {
        int n = x.length;
        Centred c = centredAndSs(x);
        double[] rho = new double[maxLag + 1];
        if (c.constant() || c.ss() == 0.0) {
            java.util.Arrays.fill(rho, Double.NaN);
            return rho;
        }
        double[] s = laggedProducts(c.d(), c.d(), maxLag, starts);
        double[] den = denominators(starts, n, maxLag, adjusted);
        double r0 = c.ss() / n;
        rho[0] = 1.0;
        for (int lag = 1; lag <= maxLag; lag++) {
            rho[lag] = (s[lag] / den[lag]) / r0;
        }
        return rho;
    }

    /** The biased ρ̂(ℓ) = S_ℓ / S_0 of one joint (portmanteau tests, Newey–West weights). */
    static double[] biasedRho(double[] x, int maxLag, int[] starts) {
        Centred c = centredAndSs(x);
        double[] rho = new double[maxLag + 1];
        if (c.ss() == 0.0) {
            java.util.Arrays.fill(rho, Double.NaN);
            return rho;
        }
        double[] s = laggedProducts(c.d(), c.d(), maxLag, starts);
        rho[0] = 1.0;
        for (int lag = 1; lag <= maxLag; lag++) {
            rho[lag] = s[lag] / c.ss();
        }
        return rho;
    }

    /**
     * Eigenvalues of a symmetric matrix (cyclic Jacobi rotations), ascending. Used for the
     * m×m noise covariance of {@code noise_model="full"}, where m is the number of joints.
     */
    static double[] symmetricEigenvalues(double[][] matrix) {
        int m = matrix.length;
        double[][] a = new double[m][];
        for (int i = 0; i < m; i++) {
            a[i] = matrix[i].clone();
        }
        for (int sweep = 0; sweep < 100; sweep++) {
            double off = 0.0;
            double diag = 0.0;
            for (int i = 0; i < m; i++) {
                diag += a[i][i] * a[i][i];
                for (int j = i + 1; j < m; j++) {
                    off += a[i][j] * a[i][j];
                }
            }
            if (off == 0.0 || off <= 1e-36 * diag) {
                break;
            }
            for (int p = 0; p < m; p++) {
                for (int q = p + 1; q < m; q++) {
                    double apq = a[p][q];
                    if (apq == 0.0) {
                        continue;
                    }
                    double theta = (a[q][q] - a[p][p]) / (2.0 * apq);
                    double t = Math.signum(theta) / (Math.abs(theta) + Math.sqrt(theta * theta + 1.0));
                    if (theta == 0.0) {
                        t = 1.0;
                    }
                    if (Double.isInfinite(theta * theta)) {
                        t = 0.5 / theta;
                    }
                    double cs = 1.0 / Math.sqrt(t * t + 1.0);
                    double sn = t * cs;
                    for (int k = 0; k < m; k++) {
                        double akp = a[k][p];
                        double akq = a[k][q];
                        a[k][p] = cs * akp - sn * akq;
                        a[k][q] = sn * akp + cs * akq;
                    }
                    for (int k = 0; k < m; k++) {
                        double apk = a[p][k];
                        double aqk = a[q][k];
                        a[p][k] = cs * apk - sn * aqk;
                        a[q][k] = sn * apk + cs * aqk;
                    }
                }
            }
        }
        double[] out = new double[m];
        for (int i = 0; i < m; i++) {
            out[i] = a[i][i];
        }
        java.util.Arrays.sort(out);
        return out;
    }
}
