package org.dynval;

import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

/**
 * The untyped entry point: one of the contract's operations by name, with inputs and conventions
 * as the corpus and the protocol carry them ({@link NdArray} data; {@code Long}, {@code Double},
 * {@code Boolean}, {@code String}, {@code List} or {@code null} parameters). Outputs are named as
 * the corpus' {@code expected} fields, with their exact shapes.
 */
public final class Operations {
    private Operations() {
    }

    /** Every operation of the corpus, in the contract's order. */
    public static final List<String> OPERATIONS = List.of(
            "residuals", "sse", "rmse", "max_abs_error", "vaf", "fit_percent", "r2",
            "residual_mean", "residual_variance", "zero_mean_test", "autocorrelation", "confidence_band",
            "ljung_box", "box_pierce", "cross_correlation", "information_criteria", "criteria", "aic", "bic",
            "accumulate");

    /** One named output: a shape, row-major values and the type to write them as. */
    public record Output(int[] shape, double[] values, NdArray.Type type) {
        static Output scalar(double v) {
            return new Output(new int[0], new double[] {v}, NdArray.Type.REAL);
        }

        static Output integer(long v) {
            return new Output(new int[0], new double[] {v}, NdArray.Type.INT);
        }

        static Output vector(double[] v) {
            return new Output(new int[] {v.length}, v.clone(), NdArray.Type.REAL);
        }

        static Output ints(int[] v) {
            double[] d = new double[v.length];
            for (int i = 0; i < v.length; i++) {
                d[i] = v[i];
            }
            return new Output(new int[] {v.length}, d, NdArray.Type.INT);
        }

        static Output matrix(double[][] rows) {
            int n = rows.length;
            int m = n == 0 ? 0 : rows[0].length;
            double[] flat = new double[n * m];
            for (int i = 0; i < n; i++) {
                System.arraycopy(rows[i], 0, flat, i * m, m);
            }
            return new Output(new int[] {n, m}, flat, NdArray.Type.REAL);
        }

        static Output metric(MetricValue v) {
            return v.isPerJoint() ? vector(v.values()) : scalar(v.value());
        }
    }

    /** Thrown for a call the contract does not define (unknown operation, missing argument). */
    public static final class UnknownCall extends RuntimeException {
        private static final long serialVersionUID = 1L;

        UnknownCall(String message) {
            super(message);
        }
    }

    private static final class Args {
        private final Map<String, Object> inputs;
        private final Map<String, Object> conventions;

        Args(Map<String, Object> inputs, Map<String, Object> conventions) {
            this.inputs = inputs;
            this.conventions = conventions;
        }

        /** A required argument (data or a per-test scalar). */
        Object required(String name) {
            if (inputs.containsKey(name)) {
                return inputs.get(name);
            }
            if (conventions.containsKey(name)) {
                return conventions.get(name);
            }
            throw new UnknownCall("missing argument " + name);
        }

        /** An optional argument: a key that is present (even as none) wins over the contract's default. */
        Object optional(String name, Object fallback) {
            if (inputs.containsKey(name)) {
                return inputs.get(name);
            }
            if (conventions.containsKey(name)) {
                return conventions.get(name);
            }
            return fallback;
        }

        Object nanPolicy() {
            return optional("nan_policy", "raise");
        }

        Object multioutput() {
            return optional("multioutput", "pooled");
        }

        Object segments() {
            return optional("segments", null);
        }
    }

    private static boolean oneD(Object x) {
        return x instanceof NdArray && ((NdArray) x).ndim() == 1;
    }

    /**
     * Evaluate one operation. Contract errors are thrown as {@link InputError}; a call the contract
     * does not define as {@link UnknownCall}.
     */
    public static Map<String, Output> run(String operation, Map<String, Object> inputs, Map<String, Object> conventions) {
        Args a = new Args(inputs, conventions);
        Map<String, Output> out = new LinkedHashMap<>();
        switch (operation) {
            case "residuals": {
                Object meas = a.required("tau_meas");
                Object pred = a.required("tau_pred");
                double[][] e = Dynval.residualsImpl(meas, pred, a.nanPolicy());
                if (oneD(meas) && oneD(pred)) {
                    double[] col = new double[e.length];
                    for (int k = 0; k < e.length; k++) {
                        col[k] = e[k][0];
                    }
                    out.put("value", Output.vector(col));
                } else {
                    out.put("value", Output.matrix(e));
                }
                break;
            }
            case "sse":
                out.put("value", Output.metric(Dynval.sseImpl(a.required("tau_meas"), a.required("tau_pred"),
                        a.multioutput(), a.nanPolicy())));
                break;
            case "max_abs_error":
                out.put("value", Output.metric(Dynval.maxAbsErrorImpl(a.required("tau_meas"), a.required("tau_pred"),
                        a.multioutput(), a.nanPolicy())));
                break;
            case "rmse":
                out.put("value", Output.metric(Dynval.rmseImpl(a.required("tau_meas"), a.required("tau_pred"),
                        a.multioutput(), a.optional("convention", null), a.nanPolicy())));
                break;
            case "vaf":
                out.put("value", Output.metric(Dynval.vafImpl(a.required("tau_meas"), a.required("tau_pred"),
                        a.multioutput(), a.nanPolicy())));
                break;
            case "fit_percent":
                out.put("value", Output.metric(Dynval.fitPercentImpl(a.required("tau_meas"), a.required("tau_pred"),
                        a.multioutput(), a.nanPolicy())));
                break;
            case "r2":
                out.put("value", Output.metric(Dynval.r2Impl(a.required("tau_meas"), a.required("tau_pred"),
                        a.multioutput(), a.nanPolicy())));
                break;
            case "residual_mean":
                out.put("value", Output.vector(Dynval.residualMeanImpl(a.required("e"), a.nanPolicy())));
                break;
            case "residual_variance":
                out.put("value", Output.vector(Dynval.residualVarianceImpl(a.required("e"), a.optional("ddof", 1L),
                        a.nanPolicy())));
                break;
            case "zero_mean_test": {
                ZeroMeanTest t = Dynval.zeroMeanTestImpl(a.required("e"), a.segments(), a.nanPolicy());
                out.put("mean", Output.vector(t.mean()));
                out.put("std", Output.vector(t.std()));
                out.put("n_samples", Output.integer(t.nSamples()));
                out.put("statistic_iid", Output.vector(t.statisticIid()));
                out.put("pvalue_iid", Output.vector(t.pvalueIid()));
                out.put("df_iid", Output.integer(t.dfIid()));
                out.put("statistic_eff", Output.vector(t.statisticEff()));
                out.put("pvalue_eff", Output.vector(t.pvalueEff()));
                out.put("df_eff", Output.vector(t.dfEff()));
                out.put("n_eff", Output.vector(t.nEff()));
                out.put("bandwidth", Output.integer(t.bandwidth()));
                break;
            }
            case "autocorrelation": {
                Object e = a.required("e");
                double[][] rho = Dynval.autocorrelationImpl(e, a.required("max_lag"), a.optional("adjusted", Boolean.TRUE),
                        a.segments(), a.nanPolicy());
                if (oneD(e)) {
                    double[] col = new double[rho.length];
                    for (int i = 0; i < rho.length; i++) {
                        col[i] = rho[i][0];
                    }
                    out.put("value", Output.vector(col));
                } else {
                    out.put("value", Output.matrix(rho));
                }
                break;
            }
            case "confidence_band":
                out.put("value", Output.scalar(Dynval.confidenceBandImpl(a.required("n"), a.optional("level", 0.95))));
                break;
            case "ljung_box":
            case "box_pierce": {
                PortmanteauTest t = Dynval.portmanteauImpl(operation, a.required("e"), a.required("lags"),
                        a.optional("model_df", 0L), a.segments(), a.nanPolicy());
                out.put("lags", Output.ints(t.lags()));
                out.put("statistic", Output.matrix(t.statistic()));
                out.put("pvalue", Output.matrix(t.pvalue()));
                out.put("log_pvalue", Output.matrix(t.logPvalue()));
                out.put("df", Output.ints(t.df()));
                break;
            }
            case "cross_correlation": {
                CrossCorrelation c = Dynval.crossCorrelationImpl(a.required("e"), a.required("regressor"),
                        a.required("max_lag"), a.optional("n_joints", null), a.optional("adjusted", Boolean.TRUE),
                        a.optional("level", 0.95), a.segments(), a.nanPolicy());
                double[][][] rho = c.rho();
                int m = rho.length;
                int p = m == 0 ? 0 : rho[0].length;
                int lags = p == 0 ? 0 : rho[0][0].length;
                double[] flat = new double[m * p * lags];
                double[] mask = new double[m * p];
                for (int j = 0; j < m; j++) {
                    for (int col = 0; col < p; col++) {
                        System.arraycopy(rho[j][col], 0, flat, (j * p + col) * lags, lags);
                        mask[j * p + col] = c.constantMask()[j][col] ? 1.0 : 0.0;
                    }
                }
                out.put("rho", new Output(new int[] {m, p, lags}, flat, NdArray.Type.REAL));
                out.put("constant_mask", new Output(new int[] {m, p}, mask, NdArray.Type.BOOL));
                out.put("band", Output.scalar(c.band()));
                break;
            }
            case "information_criteria": {
                InformationCriteria ic = Dynval.informationCriteriaImpl(a.required("rss"), a.required("n_obs"),
                        a.required("n_params"));
                putCriteria(out, ic);
                break;
            }
            case "criteria": {
                InformationCriteria ic = Dynval.criteriaImpl("criteria", a.required("tau_meas"), a.required("tau_pred"),
                        a.required("n_params"), a.optional("noise_model", "pooled"), a.nanPolicy());
                putCriteria(out, ic);
                out.put("n_obs", Output.integer(ic.nObs()));
                break;
            }
            case "aic":
            case "bic": {
                InformationCriteria ic = Dynval.criteriaImpl(operation, a.required("tau_meas"), a.required("tau_pred"),
                        a.required("n_params"), a.optional("noise_model", "pooled"), a.nanPolicy());
                out.put("value", Output.scalar(operation.equals("aic") ? ic.aic() : ic.bic()));
                break;
            }
            case "accumulate":
                return AccumulateDriver.run(inputs, conventions);
            default:
                throw new UnknownCall("unknown operation " + operation);
        }
        return out;
    }

    private static void putCriteria(Map<String, Output> out, InformationCriteria ic) {
        out.put("aic", Output.scalar(ic.aic()));
        out.put("bic", Output.scalar(ic.bic()));
        out.put("aicc", Output.scalar(ic.aicc()));
        out.put("fpe", Output.scalar(ic.fpe()));
        out.put("naic", Output.scalar(ic.naic()));
    }
}
