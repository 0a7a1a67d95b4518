package org.dynval;

import java.util.ArrayList;
import java.util.Arrays;
import java.util.List;
import java.util.function.Supplier;

/**
 * dynval's metrics for identified robot dynamic models, multi-joint: a signal is {@code double[N][m]}
 * (N samples, m joints) or {@code double[N]} for one joint, the two being the same signal.
 *
 * <p>Every function checks its input in the contract's order (type → shape → size →
 * finiteness → parameters) and throws {@link InputError} with the contract's kind and message.
 * Names follow docs/contract.md §6 in Java's casing ({@code fit_percent} → {@link #fitPercent}).
 *
 * <pre>{@code
 * double[][] meas = {{1.0, 2.0}, {2.5, 1.5}, {3.2, 0.5}};
 * double[][] pred = {{1.1, 2.1}, {2.4, 1.4}, {3.0, 0.7}};
 * double pooled = Dynval.r2(meas, pred, MultiOutput.POOLED).value();
 * double[] perJoint = Dynval.r2(meas, pred, MultiOutput.RAW_VALUES).values();
 * }</pre>
 */
public final class Dynval {
    private Dynval() {
    }

    /** Version of the contract (docs/contract.md) this library implements. */
    public static final String CONTRACT_VERSION = "1.0";

    private static final List<String> SSE_OPTIONS = List.of("pooled", "raw_values");
    private static final List<String> RMSE_OPTIONS = List.of("pooled", "raw_values", "uniform_average");

    // =================================================================== the parameter step

    /**
     * One call's data after the type, shape and size checks, and its parameter step: nan_policy,
     * then segments, then (with {@code raise}) the finiteness of the data, so that a non-finite
     * value wins over every later parameter error; with {@code omit}, the rows are deleted here.
     */
    private static final class Call {
        private final String function;
        private final String[] names;
        private final Matrix[] arrays;
        private final int[] nColumns;
        private String nanPolicy = "raise";
        int[] starts = Segments.ONE.clone();
        Matrix[] data;
        int omitted;

        Call(String function, String[] names, Matrix[] arrays, int[] nColumns, Object nanPolicy,
                Object segments, boolean takesSegments) {
            this.function = function;
            this.names = names;
            this.arrays = arrays;
            this.nColumns = nColumns;
            this.nanPolicy = check(() -> Checks.checkChoice("nan_policy", nanPolicy, Checks.NAN_POLICY_OPTIONS));
            int n = arrays[0].n();
            if (takesSegments) {
                this.starts = check(() -> Segments.parse(segments, n));
            }
            if (this.nanPolicy.equals("omit")) {
                omit();
                Checks.checkMinSamples(this.function, this.data[0].n());
            } else {
                checkAllFinite();
                this.data = arrays;
            }
        }

        private void checkAllFinite() {
            for (int i = 0; i < arrays.length; i++) {
                Checks.checkFinite(arrays[i], names[i], nColumns[i]);
            }
        }

        /** Run a parameter check; when it fails, a non-finite value in the data is reported instead. */
        <T> T check(Supplier<T> check) {
            try {
                return check.get();
            } catch (InputError error) {
                if (error.kind() == ErrorKind.INVALID_PARAMETER && !"omit".equals(nanPolicy)) {
                    checkAllFinite();
                }
                throw error;
            }
        }

        private void omit() {
            int n = arrays[0].n();
            boolean[] keep = new boolean[n];
            int kept = 0;
            for (int i = 0; i < n; i++) {
                boolean ok = true;
                for (Matrix a : arrays) {
                    for (int j = 0; j < a.m() && ok; j++) {
                        ok = Checks.inRange(a.get(i, j));
                    }
                }
                keep[i] = ok;
                if (ok) {
                    kept++;
                }
            }
            omitted = n - kept;
            if (omitted == 0) {
                data = arrays;
                return;
            }
            data = new Matrix[arrays.length];
            for (int i = 0; i < arrays.length; i++) {
                data[i] = arrays[i].keepRows(keep, kept);
            }
            starts = Segments.refine(starts, keep);
        }

        int n() {
            return data[0].n();
        }

        int limit() {
            return Segments.longest(starts, n());
        }
    }

    /** tau_meas and tau_pred after the type, shape and size checks. */
    private record Pair(Matrix meas, Matrix pred, boolean oneD) {
    }

    private static Pair signalPair(String function, Object tauMeas, Object tauPred) {
        NdArray a = Checks.toFloatArray(tauMeas, "tau_meas");
        NdArray b = Checks.toFloatArray(tauPred, "tau_pred");
        Matrix a2 = Checks.promoteSignal(a, "tau_meas");
        Matrix b2 = Checks.promoteSignal(b, "tau_pred");
        Checks.checkSameShape("tau_meas", a, a2, "tau_pred", b, b2);
        Checks.checkMinSamples(function, a2.n());
        return new Pair(a2, b2, a.ndim() == 1 && b.ndim() == 1);
    }

    private static Call pairCall(String function, Pair pair, Object nanPolicy) {
        return new Call(function, new String[] {"tau_meas", "tau_pred"}, new Matrix[] {pair.meas(), pair.pred()},
                new int[] {0, 0}, nanPolicy, null, false);
    }

    private record Residual(Matrix e, boolean oneD) {
    }

    private static Residual residualSignal(String function, Object e) {
        NdArray a = Checks.toFloatArray(e, "e");
        Matrix e2 = Checks.promoteSignal(a, "e");
        Checks.checkMinSamples(function, e2.n());
        return new Residual(e2, a.ndim() == 1);
    }

    private static Call residualCall(String function, Residual r, Object nanPolicy, Object segments, boolean takesSegments) {
        return new Call(function, new String[] {"e"}, new Matrix[] {r.e()}, new int[] {0}, nanPolicy, segments,
                takesSegments);
    }

    /** Joint-major residual columns e_j = meas_j − pred_j. */
    private static double[][] residualColumns(Matrix meas, Matrix pred) {
        int n = meas.n();
        int m = meas.m();
        double[][] out = new double[m][n];
        for (int k = 0; k < n; k++) {
            for (int j = 0; j < m; j++) {
                out[j][k] = meas.get(k, j) - pred.get(k, j);
            }
        }
        return out;
    }

    private static double[] flatResidual(Matrix meas, Matrix pred) {
        double[] a = meas.flat();
        double[] b = pred.flat();
        for (int i = 0; i < a.length; i++) {
            a[i] -= b[i];
        }
        return a;
    }

    // =================================================================== point metrics (untyped core)

    static double[][] residualsImpl(Object tauMeas, Object tauPred, Object nanPolicy) {
        Pair pair = signalPair("residuals", tauMeas, tauPred);
        Call call = pairCall("residuals", pair, nanPolicy);
        Matrix meas = call.data[0];
        Matrix pred = call.data[1];
        double[][] e = new double[meas.n()][meas.m()];
        for (int k = 0; k < meas.n(); k++) {
            for (int j = 0; j < meas.m(); j++) {
                e[k][j] = meas.get(k, j) - pred.get(k, j);
            }
        }
        return e;
    }

    static MetricValue sseImpl(Object tauMeas, Object tauPred, Object multioutput, Object nanPolicy) {
        Call call = pairCall("sse", signalPair("sse", tauMeas, tauPred), nanPolicy);
        String mo = call.check(() -> Checks.checkMultioutput(multioutput, SSE_OPTIONS, "sse"));
        if (mo.equals("pooled")) {
            return MetricValue.aggregate(Kernels.scaledSumSquares(flatResidual(call.data[0], call.data[1])).value());
        }
        double[][] e = residualColumns(call.data[0], call.data[1]);
        double[] out = new double[e.length];
        for (int j = 0; j < e.length; j++) {
            out[j] = Kernels.scaledSumSquares(e[j]).value();
        }
        return MetricValue.perJoint(out);
    }

    private static double maxAbs(double[] x) {
        double best = 0.0;
        for (double v : x) {
            best = Math.max(best, Math.abs(v));
        }
        return best;
    }

    static MetricValue maxAbsErrorImpl(Object tauMeas, Object tauPred, Object multioutput, Object nanPolicy) {
        Call call = pairCall("max_abs_error", signalPair("max_abs_error", tauMeas, tauPred), nanPolicy);
        String mo = call.check(() -> Checks.checkMultioutput(multioutput, SSE_OPTIONS, "max_abs_error"));
        if (mo.equals("pooled")) {
            return MetricValue.aggregate(maxAbs(flatResidual(call.data[0], call.data[1])));
        }
        double[][] e = residualColumns(call.data[0], call.data[1]);
        double[] out = new double[e.length];
        for (int j = 0; j < e.length; j++) {
            out[j] = maxAbs(e[j]);
        }
        return MetricValue.perJoint(out);
    }

    static MetricValue rmseImpl(Object tauMeas, Object tauPred, Object multioutput, Object convention, Object nanPolicy) {
        Call call = pairCall("rmse", signalPair("rmse", tauMeas, tauPred), nanPolicy);
        String mo = call.check(() -> Checks.checkMultioutput(multioutput, RMSE_OPTIONS, "rmse"));
        String conv = call.check(() -> Checks.checkConvention(convention, mo));
        int n = call.n();
        int m = call.data[0].m();
        if (mo.equals("pooled")) {
            Kernels.ScaledSum total = Kernels.scaledSumSquares(flatResidual(call.data[0], call.data[1]));
            return MetricValue.aggregate(total.rootMean(conv.equals("per_sample") ? n : (double) n * m));
        }
        double[][] e = residualColumns(call.data[0], call.data[1]);
        double[] out = new double[m];
        for (int j = 0; j < m; j++) {
            out[j] = Kernels.scaledSumSquares(e[j]).rootMean(n);
        }
        return mo.equals("raw_values") ? MetricValue.perJoint(out) : MetricValue.aggregate(mean(out));
    }

    /** IEEE mean over joints: −inf and nan propagate. */
    private static double mean(double[] values) {
        double s = 0.0;
        for (double v : values) {
            s += v;
        }
        return s / values.length;
    }

    /** Ingredients of vaf, fit_percent and r2 for one series (a joint, or all values pooled). */
    /** Sums of squares are scaled (contract §1.3): ratios of tiny data keep their digits. */
    record FitParts(Kernels.ScaledSum sse, Kernels.ScaledSum sscE, boolean eConstant, Kernels.ScaledSum tss,
            boolean constant) {
        static FitParts of(double[] target, double[] e) {
            Kernels.ScaledMoments me = Kernels.scaledMoments(e);
            Kernels.ScaledMoments mt = Kernels.scaledMoments(target);
            return new FitParts(Kernels.scaledSumSquares(e), me.ss(), me.constant(), mt.ss(), mt.constant());
        }
    }

    enum FitMetric { VAF, FIT_PERCENT, R2 }

    static double fitValue(FitMetric metric, FitParts p) {
        if (p.constant()) {
            boolean exact = metric == FitMetric.VAF ? p.eConstant() : p.sse().s() == 0.0;
            return exact ? Double.NaN : Double.NEGATIVE_INFINITY;
        }
        switch (metric) {
            case VAF:
                return 100.0 * (1.0 - Kernels.ScaledSum.ratio(p.sscE(), p.tss()));
            case FIT_PERCENT:
                return 100.0 * (1.0 - Math.sqrt(Kernels.ScaledSum.ratio(p.sse(), p.tss())));
            default:
                return 1.0 - Kernels.ScaledSum.ratio(p.sse(), p.tss());
        }
    }

    private static MetricValue fitImpl(FitMetric metric, String function, Object tauMeas, Object tauPred,
            Object multioutput, Object nanPolicy) {
        Call call = pairCall(function, signalPair(function, tauMeas, tauPred), nanPolicy);
        String mo = call.check(() -> Checks.checkMultioutput(multioutput, Checks.MULTIOUTPUT_OPTIONS, function));
        Matrix meas = call.data[0];
        Matrix pred = call.data[1];
        if (mo.equals("pooled")) {
            return MetricValue.aggregate(fitValue(metric, FitParts.of(meas.flat(), flatResidual(meas, pred))));
        }
        double[][] target = meas.columns();
        double[][] e = residualColumns(meas, pred);
        int m = e.length;
        FitParts[] parts = new FitParts[m];
        double[] values = new double[m];
        for (int j = 0; j < m; j++) {
            parts[j] = FitParts.of(target[j], e[j]);
            values[j] = fitValue(metric, parts[j]);
        }
        if (mo.equals("raw_values")) {
            return MetricValue.perJoint(values);
        }
        if (mo.equals("uniform_average")) {
            return MetricValue.aggregate(mean(values));
        }
        // variance_weighted: constant joints get weight 0; all constant -> the uniform average.
        // Weights are the TSS at the largest live joint's scale (contract §1.3).
        int top = Integer.MIN_VALUE;
        for (int j = 0; j < m; j++) {
            if (!parts[j].constant()) {
                top = Math.max(top, parts[j].tss().k());
            }
        }
        double num = 0.0;
        double den = 0.0;
        boolean live = false;
        for (int j = 0; j < m; j++) {
            if (!parts[j].constant()) {
                double w = Math.scalb(parts[j].tss().s(), 2 * (parts[j].tss().k() - top));
                num += w * values[j];
                den += w;
                live = true;
            }
        }
        return MetricValue.aggregate(live && den != 0.0 ? num / den : mean(values));
    }

    static MetricValue vafImpl(Object tauMeas, Object tauPred, Object multioutput, Object nanPolicy) {
        return fitImpl(FitMetric.VAF, "vaf", tauMeas, tauPred, multioutput, nanPolicy);
    }

    static MetricValue fitPercentImpl(Object tauMeas, Object tauPred, Object multioutput, Object nanPolicy) {
        return fitImpl(FitMetric.FIT_PERCENT, "fit_percent", tauMeas, tauPred, multioutput, nanPolicy);
    }

    static MetricValue r2Impl(Object tauMeas, Object tauPred, Object multioutput, Object nanPolicy) {
        return fitImpl(FitMetric.R2, "r2", tauMeas, tauPred, multioutput, nanPolicy);
    }

    // =================================================================== residual statistics (untyped core)

    static double[] residualMeanImpl(Object e, Object nanPolicy) {
        Call call = residualCall("residual_mean", residualSignal("residual_mean", e), nanPolicy, null, false);
        double[][] cols = call.data[0].columns();
        double[] out = new double[cols.length];
        for (int j = 0; j < cols.length; j++) {
            out[j] = Kernels.scaledMoments(cols[j]).mean();
        }
        return out;
    }

    static double[] residualVarianceImpl(Object e, Object ddof, Object nanPolicy) {
        Call call = residualCall("residual_variance", residualSignal("residual_variance", e), nanPolicy, null, false);
        int d = call.check(() -> Checks.checkDdof(ddof, call.n()));
        return variances(call.data[0].columns(), d);
    }

    private static double[] variances(double[][] cols, int ddof) {
        double[] out = new double[cols.length];
        for (int j = 0; j < cols.length; j++) {
            Kernels.ScaledSum ss = Kernels.scaledMoments(cols[j]).ss();
            out[j] = Math.scalb(ss.s() / (cols[j].length - ddof), 2 * ss.k());
        }
        return out;
    }

    /** K = ⌊4(N/100)^(2/9)⌋, at most N − 1 (contract §3.3). */
    static int neweyWestBandwidth(int n) {
        return (int) Math.min(Math.floor(4.0 * Math.pow(n / 100.0, 2.0 / 9.0)), n - 1);
    }

    static ZeroMeanTest zeroMeanTestImpl(Object e, Object segments, Object nanPolicy) {
        Call call = residualCall("zero_mean_test", residualSignal("zero_mean_test", e), nanPolicy, segments, true);
        int n = call.n();
        double[][] cols = call.data[0].columns();
        int m = cols.length;
        int k = neweyWestBandwidth(n);
        // Lags past the longest segment have no products: their ρ̂ is 0 and adds nothing.
        int kUsed = Math.min(k, call.limit() - 1);
        double[] mean = new double[m];
        double[] std = new double[m];
        double[] tIid = new double[m];
        double[] pIid = new double[m];
        double[] tEff = new double[m];
        double[] pEff = new double[m];
        double[] dfEff = new double[m];
        double[] nEff = new double[m];
        for (int j = 0; j < m; j++) {
            // t is a ratio: computed on the series scaled by a power of two (contract §1.3).
            int scale = Kernels.scaleExponent(cols[j]);
            Kernels.Moments mo = Kernels.moments(Kernels.scaled(cols[j], scale));
            double meanScaled = mo.mean();
            double stdScaled = Math.sqrt(mo.ss() / (n - 1));
            mean[j] = Math.scalb(meanScaled, scale);
            std[j] = Math.scalb(stdScaled, scale);
            double total = 0.0;
            if (kUsed > 0) {
                double[] rho = Kernels.biasedRho(cols[j], kUsed, call.starts);
                for (int lag = 1; lag <= kUsed; lag++) {
                    total += (1.0 - lag / (k + 1.0)) * rho[lag];
                }
            }
            double ne;
            if (Double.isNaN(total) || total <= 0) {
                ne = n;
            } else {
                ne = Math.min(Math.max(n / (1.0 + 2.0 * total), 2.0), n);
            }
            nEff[j] = ne;
            dfEff[j] = ne - 1.0;
            tIid[j] = meanScaled * Math.sqrt(n) / stdScaled;
            tEff[j] = meanScaled * Math.sqrt(ne) / stdScaled;
            pIid[j] = Special.studentTwoSided(tIid[j], n - 1);
            pEff[j] = Special.studentTwoSided(tEff[j], ne - 1.0);
        }
        return new ZeroMeanTest(mean, std, n, tIid, pIid, n - 1, tEff, pEff, dfEff, nEff, k);
    }

    // =================================================================== correlation (untyped core)

    static double[][] autocorrelationImpl(Object e, Object maxLag, Object adjusted, Object segments, Object nanPolicy) {
        Call call = residualCall("autocorrelation", residualSignal("autocorrelation", e), nanPolicy, segments, true);
        int lagMax = call.check(() -> Checks.checkMaxLag(maxLag, call.limit()));
        boolean adj = call.check(() -> Checks.checkAdjusted(adjusted));
        double[][] cols = call.data[0].columns();
        double[][] out = new double[lagMax + 1][cols.length];
        for (int j = 0; j < cols.length; j++) {
            double[] rho = Kernels.autocorrelation(cols[j], lagMax, adj, call.starts);
            for (int lag = 0; lag <= lagMax; lag++) {
                out[lag][j] = rho[lag];
            }
        }
        return out;
    }

    static double confidenceBandImpl(Object n, Object level) {
        long count = Checks.checkN(n);
        double lv = Checks.checkLevel(level);
        return Special.normalHalfWidth(lv) / Math.sqrt((double) count);
    }

    static PortmanteauTest portmanteauImpl(String test, Object e, Object lags, Object modelDf, Object segments,
            Object nanPolicy) {
        Call call = residualCall(test, residualSignal(test, e), nanPolicy, segments, true);
        int[] h = call.check(() -> Checks.checkLags(lags, call.limit()));
        int minLag = Arrays.stream(h).min().getAsInt();
        int hMax = Arrays.stream(h).max().getAsInt();
        int mdf = call.check(() -> Checks.checkModelDf(modelDf, minLag));
        int n = call.n();
        double[][] cols = call.data[0].columns();
        int m = cols.length;
        double[][] stat = new double[h.length][m];
        double[][] pv = new double[h.length][m];
        double[][] logp = new double[h.length][m];
        int[] df = new int[h.length];
        for (int i = 0; i < h.length; i++) {
            df[i] = h[i] - mdf;
        }
        for (int j = 0; j < m; j++) {
            double[] rho = Kernels.biasedRho(cols[j], hMax, call.starts);
            double[] cumulative = new double[hMax + 1];
            double running = 0.0;
            for (int lag = 1; lag <= hMax; lag++) {
                double r2 = rho[lag] * rho[lag];
                running += test.equals("ljung_box") ? r2 / Segments.productCount(call.starts, n, lag) : r2;
                cumulative[lag] = running;
            }
            for (int i = 0; i < h.length; i++) {
                double q = test.equals("ljung_box")
                        ? n * (n + 2.0) * cumulative[h[i]]
                        : n * cumulative[h[i]];
                stat[i][j] = q;
                pv[i][j] = Special.chi2Sf(q, df[i]);
                logp[i][j] = Special.chi2LogSf(q, df[i]);
            }
        }
        return new PortmanteauTest(test, h.clone(), mdf, stat, pv, logp, df);
    }

    static CrossCorrelation crossCorrelationImpl(Object e, Object regressor, Object maxLag, Object nJoints,
            Object adjusted, Object level, Object segments, Object nanPolicy) {
        NdArray eArr = Checks.toFloatArray(e, "e");
        NdArray yArr = Checks.toFloatArray(regressor, "regressor");
        Matrix e2 = Checks.promoteSignal(eArr, "e");
        int n = e2.n();
        int m = e2.m();
        int p = Checks.regressorShape(yArr, "e", n, m, nJoints);
        Checks.checkMinSamples("cross_correlation", n);
        // Both accepted forms hold sample k, joint j, column c at flat position (k·m + j)·p + c.
        Matrix y2 = Matrix.fromRowMajor(yArr.data(), n, m * p);
        Call call = new Call("cross_correlation", new String[] {"e", "regressor"}, new Matrix[] {e2, y2},
                new int[] {0, p}, nanPolicy, segments, true);
        int lagMax = call.check(() -> Checks.checkMaxLag(maxLag, call.limit()));
        call.check(() -> {
            Checks.checkNJoints(nJoints, yArr.dim(0), m, yArr.ndim() == 3);
            return null;
        });
        boolean adj = call.check(() -> Checks.checkAdjusted(adjusted));
        double lv = call.check(() -> Checks.checkLevel(level));
        int nn = call.n();
        double[][] eCols = call.data[0].columns();
        double[][] yCols = call.data[1].columns();
        double[] den = Kernels.denominators(call.starts, nn, lagMax, adj);
        double[][][] rho = new double[m][p][lagMax + 1];
        boolean[][] mask = new boolean[m][p];
        for (int j = 0; j < m; j++) {
            Kernels.Centred ce = Kernels.centredAndSs(eCols[j]);
            for (int c = 0; c < p; c++) {
                Kernels.Centred cy = Kernels.centredAndSs(yCols[j * p + c]);
                mask[j][c] = cy.constant();
                if (cy.constant() || ce.constant() || ce.ss() == 0.0 || cy.ss() == 0.0) {
                    Arrays.fill(rho[j][c], Double.NaN);
                    continue;
                }
                double[] s = Kernels.laggedProducts(ce.d(), cy.d(), lagMax, call.starts);
                // Two roots, not the root of the product (contract §1.3).
                double scale = Math.sqrt(ce.ss() / nn) * Math.sqrt(cy.ss() / nn);
                for (int lag = 0; lag <= lagMax; lag++) {
                    rho[j][c][lag] = (s[lag] / den[lag]) / scale;
                }
            }
        }
        double band = Special.normalHalfWidth(lv) / Math.sqrt(nn);
        return new CrossCorrelation(rho, mask, band, lv);
    }

    // =================================================================== information criteria (untyped core)

    static InformationCriteria assemble(double fitTerm, long n, double nVec, double size, long p,
            String noiseModel) {
        double aic = fitTerm + 2.0 * p;
        double bic = fitTerm + p * Math.log(n);
        double aicc;
        double fpe;
        if (p < n - 1) {
            aicc = aic + 2.0 * p * ((double) p + 1.0) / (double) (n - p - 1);
            double ratio = (double) p / (double) n;
            fpe = size * (1 + ratio) / (1 - ratio);
        } else {
            aicc = Double.NaN;
            fpe = Double.NaN;
        }
        double naic = fitTerm / nVec + 2.0 * p / n;
        return new InformationCriteria(aic, bic, aicc, fpe, naic, n, p, noiseModel);
    }

    /** n·ln(σ²), −inf for σ² = 0. */
    private static double nLog(double n, double variance) {
        return variance == 0.0 ? Double.NEGATIVE_INFINITY : n * Math.log(variance);
    }

    static InformationCriteria informationCriteriaImpl(Object rss, Object nObs, Object nParams) {
        double r = Checks.checkRss(rss);
        long n = Checks.checkNObs(nObs);
        long p = Checks.checkNParams(nParams, n);
        double variance = r / n;
        return assemble(nLog(n, variance), n, n, variance, p, "pooled");
    }

    static InformationCriteria criteriaImpl(String function, Object tauMeas, Object tauPred, Object nParams,
            Object noiseModel, Object nanPolicy) {
        Call call = pairCall(function, signalPair(function, tauMeas, tauPred), nanPolicy);
        long p = call.check(() -> Checks.checkNParams(nParams));
        String model = call.check(() -> Checks.checkChoice("noise_model", noiseModel, Checks.NOISE_MODEL_OPTIONS));
        double[][] e = residualColumns(call.data[0], call.data[1]);
        int n = call.n();
        int m = e.length;
        if (model.equals("pooled")) {
            Kernels.ScaledSum total = Kernels.scaledSumSquares(flatResidual(call.data[0], call.data[1]));
            long nv = (long) n * m;
            if (total.s() == 0.0) {
                return assemble(Double.NEGATIVE_INFINITY, nv, nv, 0.0, p, model);
            }
            return assemble(nv * total.logMean(nv), nv, nv, Math.scalb(total.s() / nv, 2 * total.k()), p, model);
        }
        if (model.equals("per_joint")) {
            double[] logs = new double[m];
            for (int j = 0; j < m; j++) {
                Kernels.ScaledSum sse = Kernels.scaledSumSquares(e[j]);
                if (sse.s() == 0.0) {
                    return assemble(Double.NEGATIVE_INFINITY, n, n, 0.0, p, model);
                }
                logs[j] = sse.logMean(n);
            }
            double logSize = Kernels.sum(logs);
            return assemble(n * logSize, n, n, Math.exp(logSize), p, model);
        }
        // full: Σ̂ = EᵀE/N (m×m, not demeaned); singular by numpy's matrix_rank tolerance. E is
        // scaled by one power of two for every joint (eigenvalue ratios stay; ln det gains 2k·m·ln 2).
        int scale = Kernels.scaleExponent(flatResidual(call.data[0], call.data[1]));
        for (int j = 0; j < m; j++) {
            e[j] = Kernels.scaled(e[j], scale);
        }
        double[][] sigma = new double[m][m];
        double[] products = new double[n];
        for (int a = 0; a < m; a++) {
            for (int b = a; b < m; b++) {
                for (int k = 0; k < n; k++) {
                    products[k] = e[a][k] * e[b][k];
                }
                sigma[a][b] = Kernels.sum(products) / n;
                sigma[b][a] = sigma[a][b];
            }
        }
        double[] eig = Kernels.symmetricEigenvalues(sigma);
        double largest = eig[m - 1];
        if (largest <= 0.0 || eig[0] <= m * Math.ulp(1.0) * largest) {
            return assemble(Double.NEGATIVE_INFINITY, n, n, 0.0, p, model);
        }
        double[] logs = new double[m];
        for (int i = 0; i < m; i++) {
            logs[i] = Math.log(eig[i]);
        }
        double logDet = Kernels.sum(logs) + 2.0 * scale * m * Math.log(2.0);
        return assemble(n * logDet, n, n, Math.exp(logDet), p, model);
    }

    // =================================================================== public, typed API

    private static String name(MultiOutput mo) {
        return mo.contractName();
    }

    private static String name(NanPolicy np) {
        return np.contractName();
    }

    private static List<Long> segmentList(int[] segments) {
        if (segments == null) {
            return null;
        }
        List<Long> out = new ArrayList<>();
        for (int s : segments) {
            out.add((long) s);
        }
        return out;
    }

    /** e = τ_meas − τ_pred, {@code (N, m)}. */
    public static double[][] residuals(double[][] tauMeas, double[][] tauPred) {
        return residualsImpl(tauMeas, tauPred, "raise");
    }

    /** e = τ_meas − τ_pred for one joint, {@code (N,)}. */
    public static double[] residuals(double[] tauMeas, double[] tauPred) {
        double[][] e = residualsImpl(tauMeas, tauPred, "raise");
        double[] out = new double[e.length];
        for (int k = 0; k < e.length; k++) {
            out[k] = e[k][0];
        }
        return out;
    }

    /** Sum of squared errors; {@code multioutput} POOLED or RAW_VALUES. */
    public static MetricValue sse(double[][] tauMeas, double[][] tauPred, MultiOutput multioutput) {
        return sseImpl(tauMeas, tauPred, name(multioutput), "raise");
    }

    /** Largest absolute residual; {@code multioutput} POOLED or RAW_VALUES. */
    public static MetricValue maxAbsError(double[][] tauMeas, double[][] tauPred, MultiOutput multioutput) {
        return maxAbsErrorImpl(tauMeas, tauPred, name(multioutput), "raise");
    }

    /** RMSE: POOLED (per element), RAW_VALUES or UNIFORM_AVERAGE. */
    public static MetricValue rmse(double[][] tauMeas, double[][] tauPred, MultiOutput multioutput) {
        return rmseImpl(tauMeas, tauPred, name(multioutput), null, "raise");
    }

    /** Pooled RMSE under an explicit convention (per element √(SSE/(N·m)) or per sample √(SSE/N)). */
    public static double rmse(double[][] tauMeas, double[][] tauPred, RmseConvention convention) {
        return rmseImpl(tauMeas, tauPred, "pooled", convention.contractName(), "raise").value();
    }

    /** Variance accounted for, percent. */
    public static MetricValue vaf(double[][] tauMeas, double[][] tauPred, MultiOutput multioutput) {
        return vafImpl(tauMeas, tauPred, name(multioutput), "raise");
    }

    /** Normalised fit 100(1 − √(SSE/TSS)), percent. */
    public static MetricValue fitPercent(double[][] tauMeas, double[][] tauPred, MultiOutput multioutput) {
        return fitPercentImpl(tauMeas, tauPred, name(multioutput), "raise");
    }

    /** Coefficient of determination 1 − SSE/TSS. */
    public static MetricValue r2(double[][] tauMeas, double[][] tauPred, MultiOutput multioutput) {
        return r2Impl(tauMeas, tauPred, name(multioutput), "raise");
    }

    /** R² with an explicit nan_policy ({@code OMIT} deletes rows holding a non-finite value). */
    public static MetricValue r2(double[][] tauMeas, double[][] tauPred, MultiOutput multioutput, NanPolicy nanPolicy) {
        return r2Impl(tauMeas, tauPred, name(multioutput), name(nanPolicy));
    }

    /** SSE with an explicit nan_policy. */
    public static MetricValue sse(double[][] tauMeas, double[][] tauPred, MultiOutput multioutput, NanPolicy nanPolicy) {
        return sseImpl(tauMeas, tauPred, name(multioutput), name(nanPolicy));
    }

    /** Max abs error with an explicit nan_policy. */
    public static MetricValue maxAbsError(double[][] tauMeas, double[][] tauPred, MultiOutput multioutput,
            NanPolicy nanPolicy) {
        return maxAbsErrorImpl(tauMeas, tauPred, name(multioutput), name(nanPolicy));
    }

    /** RMSE with an explicit nan_policy. */
    public static MetricValue rmse(double[][] tauMeas, double[][] tauPred, MultiOutput multioutput, NanPolicy nanPolicy) {
        return rmseImpl(tauMeas, tauPred, name(multioutput), null, name(nanPolicy));
    }

    /** VAF with an explicit nan_policy. */
    public static MetricValue vaf(double[][] tauMeas, double[][] tauPred, MultiOutput multioutput, NanPolicy nanPolicy) {
        return vafImpl(tauMeas, tauPred, name(multioutput), name(nanPolicy));
    }

    /** Fit percent with an explicit nan_policy. */
    public static MetricValue fitPercent(double[][] tauMeas, double[][] tauPred, MultiOutput multioutput,
            NanPolicy nanPolicy) {
        return fitPercentImpl(tauMeas, tauPred, name(multioutput), name(nanPolicy));
    }

    /** Mean of each joint's residual, {@code (m,)}. */
    public static double[] residualMean(double[][] e) {
        return residualMeanImpl(e, "raise");
    }

    /** Σ(e − ē_j)²/(N − ddof) per joint, {@code (m,)}. */
    public static double[] residualVariance(double[][] e, int ddof) {
        return residualVarianceImpl(e, (long) ddof, "raise");
    }

    /** Zero-mean test per joint; {@code segments} as lengths or starts, or null for one record. */
    public static ZeroMeanTest zeroMeanTest(double[][] e, int[] segments) {
        return zeroMeanTestImpl(e, segmentList(segments), "raise");
    }

    /** ρ̂(ℓ), ℓ = 0..maxLag, {@code [maxLag+1][m]}; adjusted (the lesson) or biased. */
    public static double[][] autocorrelation(double[][] e, int maxLag, boolean adjusted, int[] segments) {
        return autocorrelationImpl(e, (long) maxLag, adjusted, segmentList(segments), "raise");
    }

    /** The lesson's single-joint autocorrelation, {@code (maxLag+1,)}, adjusted. */
    public static double[] autocorrelation(double[] e, int maxLag) {
        double[][] rho = autocorrelationImpl(e, (long) maxLag, true, null, "raise");
        double[] out = new double[rho.length];
        for (int i = 0; i < rho.length; i++) {
            out[i] = rho[i][0];
        }
        return out;
    }

    /** Autocorrelation with an explicit nan_policy ({@code OMIT} inserts a segment break where rows were deleted). */
    public static double[][] autocorrelation(double[][] e, int maxLag, boolean adjusted, int[] segments,
            NanPolicy nanPolicy) {
        return autocorrelationImpl(e, (long) maxLag, adjusted, segmentList(segments), name(nanPolicy));
    }

    /** Zero-mean test with an explicit nan_policy. */
    public static ZeroMeanTest zeroMeanTest(double[][] e, int[] segments, NanPolicy nanPolicy) {
        return zeroMeanTestImpl(e, segmentList(segments), name(nanPolicy));
    }

    /** Residual mean and variance with an explicit nan_policy. */
    public static double[] residualMean(double[][] e, NanPolicy nanPolicy) {
        return residualMeanImpl(e, name(nanPolicy));
    }

    public static double[] residualVariance(double[][] e, int ddof, NanPolicy nanPolicy) {
        return residualVarianceImpl(e, (long) ddof, name(nanPolicy));
    }

    /** Half-width z/√n of the white-noise band, z = Φ⁻¹((1 + level)/2). */
    public static double confidenceBand(long n, double level) {
        return confidenceBandImpl(n, level);
    }

    private static List<Long> lagList(int[] lags) {
        List<Long> out = new ArrayList<>();
        for (int h : lags) {
            out.add((long) h);
        }
        return out;
    }

    /** Ljung–Box Q(h) at each lag h on the biased autocorrelation, df = h − modelDf. */
    public static PortmanteauTest ljungBox(double[][] e, int[] lags, int modelDf, int[] segments) {
        return portmanteauImpl("ljung_box", e, lagList(lags), (long) modelDf, segmentList(segments), "raise");
    }

    /** Box–Pierce Q(h) = N Σ ρ̂²; arguments as {@link #ljungBox}. */
    public static PortmanteauTest boxPierce(double[][] e, int[] lags, int modelDf, int[] segments) {
        return portmanteauImpl("box_pierce", e, lagList(lags), (long) modelDf, segmentList(segments), "raise");
    }

    /** Ljung–Box with an explicit nan_policy. */
    public static PortmanteauTest ljungBox(double[][] e, int[] lags, int modelDf, int[] segments, NanPolicy nanPolicy) {
        return portmanteauImpl("ljung_box", e, lagList(lags), (long) modelDf, segmentList(segments), name(nanPolicy));
    }

    /** Box–Pierce with an explicit nan_policy. */
    public static PortmanteauTest boxPierce(double[][] e, int[] lags, int modelDf, int[] segments, NanPolicy nanPolicy) {
        return portmanteauImpl("box_pierce", e, lagList(lags), (long) modelDf, segmentList(segments), name(nanPolicy));
    }

    /** Cross-correlation with an explicit nan_policy (rows non-finite in e or in the regressor are deleted). */
    public static CrossCorrelation crossCorrelation(double[][] e, double[][][] regressor, int maxLag, boolean adjusted,
            double level, int[] segments, NanPolicy nanPolicy) {
        return crossCorrelationImpl(e, regressor, (long) maxLag, null, adjusted, level, segmentList(segments),
                name(nanPolicy));
    }

    /** Cross-correlation of e {@code (N, m)} with a regressor {@code [N][m][p]}. */
    public static CrossCorrelation crossCorrelation(double[][] e, double[][][] regressor, int maxLag, boolean adjusted,
            double level, int[] segments) {
        return crossCorrelationImpl(e, regressor, (long) maxLag, null, adjusted, level, segmentList(segments), "raise");
    }

    /** Criteria from a residual sum of squares: σ̂² = rss/n (requires nParams < nObs − 1). */
    public static InformationCriteria informationCriteria(double rss, long nObs, long nParams) {
        return informationCriteriaImpl(rss, nObs, nParams);
    }

    /** Criteria of τ_meas − τ_pred under a noise model (n_params always given: there is no default). */
    public static InformationCriteria criteria(double[][] tauMeas, double[][] tauPred, long nParams, NoiseModel noiseModel) {
        return criteriaImpl("criteria", tauMeas, tauPred, nParams, noiseModel.contractName(), "raise");
    }

    /** Criteria with an explicit nan_policy. */
    public static InformationCriteria criteria(double[][] tauMeas, double[][] tauPred, long nParams, NoiseModel noiseModel,
            NanPolicy nanPolicy) {
        return criteriaImpl("criteria", tauMeas, tauPred, nParams, noiseModel.contractName(), name(nanPolicy));
    }

    /** AIC of the noise model (constant dropped). */
    public static double aic(double[][] tauMeas, double[][] tauPred, long nParams, NoiseModel noiseModel) {
        return criteriaImpl("aic", tauMeas, tauPred, nParams, noiseModel.contractName(), "raise").aic();
    }

    /** BIC of the noise model (constant dropped). */
    public static double bic(double[][] tauMeas, double[][] tauPred, long nParams, NoiseModel noiseModel) {
        return criteriaImpl("bic", tauMeas, tauPred, nParams, noiseModel.contractName(), "raise").bic();
    }
}
