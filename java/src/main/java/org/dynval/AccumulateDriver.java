package org.dynval;

import java.util.ArrayList;
import java.util.Arrays;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Locale;
import java.util.Map;
import java.util.TreeSet;

/**
 * The corpus operation {@code accumulate} (family {@code streaming}, docs/contract.md §4.1 "In the
 * corpus"): the rows are handed to {@link ValidationAccumulator}s in the blocks of the convention
 * {@code chunks}, with a break wherever a record of {@code segments} starts, and the per-block
 * accumulators are combined in the order {@code merge} names. It mirrors the Python reference
 * driver ({@code dynval.golden._ops._accumulate}).
 */
final class AccumulateDriver {
    private AccumulateDriver() {
    }

    private static final List<String> MERGE_OPTIONS = List.of("none", "left", "right", "tree");
    private static final List<String> NAN_POLICY_OPTIONS = List.of("raise");

    static Map<String, Operations.Output> run(Map<String, Object> inputs, Map<String, Object> conventions) {
        Object meas = required(inputs, "tau_meas");
        Object pred = required(inputs, "tau_pred");
        Object reg = inputs.get("regressor");
        Object nanPolicy = conventions.getOrDefault("nan_policy", "raise");
        // The in-memory operations' data checks come first, so that the errors are those of the
        // other families. "omit" is refused below, after the data: a refused policy must not
        // hide a non-finite value.
        Object dataPolicy = "omit".equals(nanPolicy) ? "raise" : nanPolicy;
        Dynval.criteriaImpl("criteria", meas, pred, 0L, "pooled", dataPolicy);
        if (reg != null) {
            Dynval.crossCorrelationImpl(Dynval.residualsImpl(meas, pred, dataPolicy), reg, 0L, null, Boolean.TRUE, 0.95, null, dataPolicy);
        }
        Checks.checkChoice("nan_policy", nanPolicy, NAN_POLICY_OPTIONS);
        double[][] tau = rows(Checks.toFloatArray(meas, "tau_meas"));
        int n = tau.length;
        int[] ends = blockEnds(conventions.get("chunks"), n);
        String merge = Checks.checkChoice("merge", conventions.getOrDefault("merge", "none"), MERGE_OPTIONS);
        int[] starts = Segments.parse(conventions.get("segments"), n);
        long nParams = Checks.checkNParams(required(inputs, "n_params"));
        int maxLag = Checks.checkMaxLag(required(inputs, "max_lag"), Segments.longest(starts, n));
        String noise = Checks.checkChoice("noise_model", conventions.getOrDefault("noise_model", "pooled"),
                Checks.NOISE_MODEL_OPTIONS);
        NoiseModel noiseModel = NoiseModel.valueOf(noise.toUpperCase(Locale.ROOT));

        double[][] predRows = rows(Checks.toFloatArray(pred, "tau_pred"));
        double[][][] regRows = reg == null ? null : cube(Checks.toFloatArray(reg, "regressor"));
        TreeSet<Integer> recordStarts = new TreeSet<>();
        for (int s : starts) {
            if (s > 0) {
                recordStarts.add(s);
            }
        }

        List<ValidationAccumulator> parts = new ArrayList<>();
        ValidationAccumulator acc = null;
        int a = 0;
        for (int b : ends) {
            if (acc == null || !merge.equals("none")) {
                acc = new ValidationAccumulator(nParams, maxLag, noiseModel);
                parts.add(acc);
            }
            feed(acc, tau, predRows, regRows, a, b, recordStarts);
            a = b;
        }
        ValidationAccumulator.Metrics r = combine(parts, merge).result();

        Map<String, Operations.Output> out = new LinkedHashMap<>();
        out.put("sse", Operations.Output.vector(r.sse()));
        out.put("rmse", Operations.Output.vector(r.rmse()));
        out.put("max_abs_error", Operations.Output.vector(r.maxAbsError()));
        out.put("vaf", Operations.Output.vector(r.vaf()));
        out.put("fit_percent", Operations.Output.vector(r.fitPercent()));
        out.put("r2", Operations.Output.vector(r.r2()));
        out.put("residual_mean", Operations.Output.vector(r.residualMean()));
        out.put("residual_variance", Operations.Output.vector(r.residualVariance()));
        out.put("autocorrelation", Operations.Output.matrix(r.autocorrelation()));
        if (r.rho() != null) {
            out.put("rho", cubeOutput(r.rho()));
        }
        InformationCriteria ic = r.criteria();
        out.put("aic", Operations.Output.scalar(ic.aic()));
        out.put("bic", Operations.Output.scalar(ic.bic()));
        out.put("aicc", Operations.Output.scalar(ic.aicc()));
        out.put("fpe", Operations.Output.scalar(ic.fpe()));
        out.put("naic", Operations.Output.scalar(ic.naic()));
        return out;
    }

    private static Object required(Map<String, Object> inputs, String name) {
        if (!inputs.containsKey(name)) {
            throw new Operations.UnknownCall("missing argument " + name);
        }
        return inputs.get(name);
    }

    /** Exclusive ends of the blocks of {@code chunks}: positive lengths summing to N. */
    static int[] blockEnds(Object chunks, int n) {
        InputError error = Checks.parameterError("chunks", "a non-empty list of positive lengths summing to N=" + n,
                chunks);
        if (!(chunks instanceof List) || ((List<?>) chunks).isEmpty()) {
            throw error;
        }
        List<?> lengths = (List<?>) chunks;
        int[] ends = new int[lengths.size()];
        long total = 0;
        for (int i = 0; i < ends.length; i++) {
            Object v = lengths.get(i);
            if (!Checks.isInteger(v) || Checks.asLong(v) < 1) {
                throw error;
            }
            total += Checks.asLong(v);
            if (total > n) {
                throw error; // also keeps the running sum far from overflow
            }
            ends[i] = (int) total;
        }
        if (total != n) {
            throw error;
        }
        return ends;
    }

    /**
     * Rows [a, b) to one accumulator: split where a record starts inside the block, with a break
     * between the parts; a record starting at the block's first row is a break before it.
     */
    private static void feed(ValidationAccumulator acc, double[][] meas, double[][] pred, double[][][] reg, int a,
            int b, TreeSet<Integer> recordStarts) {
        if (recordStarts.contains(a)) {
            acc.breakSegment();
        }
        int lo = a;
        for (int cut : recordStarts.subSet(a, false, b, false)) {
            update(acc, meas, pred, reg, lo, cut);
            acc.breakSegment();
            lo = cut;
        }
        update(acc, meas, pred, reg, lo, b);
    }

    private static void update(ValidationAccumulator acc, double[][] meas, double[][] pred, double[][][] reg, int a,
            int b) {
        double[][] m = Arrays.copyOfRange(meas, a, b);
        double[][] p = Arrays.copyOfRange(pred, a, b);
        acc.update(m, p, reg == null ? null : Arrays.copyOfRange(reg, a, b));
    }

    /** One accumulator from the blocks' own, combined in the order {@code merge} names. */
    static ValidationAccumulator combine(List<ValidationAccumulator> parts, String merge) {
        switch (merge) {
            case "none":
            case "left": {
                ValidationAccumulator out = parts.get(0);
                for (int i = 1; i < parts.size(); i++) {
                    out = out.merge(parts.get(i));
                }
                return out;
            }
            case "right": {
                ValidationAccumulator out = parts.get(parts.size() - 1);
                for (int i = parts.size() - 2; i >= 0; i--) {
                    out = parts.get(i).merge(out);
                }
                return out;
            }
            default: {
                // tree: adjacent pairs level by level, an odd last one passed up unchanged
                List<ValidationAccumulator> level = parts;
                while (level.size() > 1) {
                    List<ValidationAccumulator> next = new ArrayList<>();
                    for (int k = 0; k < level.size(); k += 2) {
                        next.add(k + 1 < level.size() ? level.get(k).merge(level.get(k + 1)) : level.get(k));
                    }
                    level = next;
                }
                return level.get(0);
            }
        }
    }

    /** A signal (N,) or (N, m) as rows of m values. */
    private static double[][] rows(NdArray x) {
        int n = x.dim(0);
        int m = x.ndim() == 1 ? 1 : x.dim(1);
        double[] flat = x.data();
        double[][] out = new double[n][m];
        for (int k = 0; k < n; k++) {
            System.arraycopy(flat, k * m, out[k], 0, m);
        }
        return out;
    }

    /** A regressor (N, m, p) as {@code [N][m][p]}. */
    private static double[][][] cube(NdArray y) {
        int n = y.dim(0);
        int m = y.dim(1);
        int p = y.dim(2);
        double[] flat = y.data();
        double[][][] out = new double[n][m][p];
        for (int k = 0; k < n; k++) {
            for (int j = 0; j < m; j++) {
                System.arraycopy(flat, (k * m + j) * p, out[k][j], 0, p);
            }
        }
        return out;
    }

    private static Operations.Output cubeOutput(double[][][] rho) {
        int m = rho.length;
        int p = rho[0].length;
        int lags = rho[0][0].length;
        double[] flat = new double[m * p * lags];
        for (int j = 0; j < m; j++) {
            for (int c = 0; c < p; c++) {
                System.arraycopy(rho[j][c], 0, flat, (j * p + c) * lags, lags);
            }
        }
        return new Operations.Output(new int[] {m, p, lags}, flat, NdArray.Type.REAL);
    }
}
