package org.dynval;

/**
 * The lesson's {@code ValidationMetricsJava.compute(tauMeas, tauPred, pParams)}, multi-joint:
 * every point metric per joint, pooled (the lesson's flattened form) and aggregated, and the
 * information criteria of the pooled noise model, as the contract's {@code compute_metrics}
 * (docs/contract.md §5.1). The lesson's bare {@code rmse} is split into
 * {@code rmsePerElement} (its formula) and {@code rmsePerSample} (its code); they agree for one joint.
 */
public final class ValidationMetrics {
    private ValidationMetrics() {
    }

    /** All metrics of one model: arrays are per joint {@code (m,)}. */
    public record Metrics(
            int nSamples,
            int nJoints,
            long nParams,
            double[] sse,
            double[] rmse,
            double[] maxAbsError,
            double[] vaf,
            double[] fitPercent,
            double[] r2,
            double[] residualMean,
            double[] residualVariance,
            double sseTotal,
            double rmsePerElement,
            double rmsePerSample,
            double maxAbsErrorPooled,
            double vafPooled,
            double fitPercentPooled,
            double r2Pooled,
            double rmseUniformAverage,
            double vafUniformAverage,
            double fitPercentUniformAverage,
            double r2UniformAverage,
            double vafVarianceWeighted,
            double fitPercentVarianceWeighted,
            double r2VarianceWeighted,
            double aic,
            double bic,
            double aicc,
            double fpe,
            double naic) {
    }

    /** {@link #compute(double[][], double[][], long, int)} with the residual variance over N − 1, as the lesson. */
    public static Metrics compute(double[][] tauMeas, double[][] tauPred, long nParams) {
        return compute(tauMeas, tauPred, nParams, 1);
    }

    /**
     * Every metric of {@code tauMeas} (N, m) against {@code tauPred} (N, m), N >= 2. When
     * nParams >= N·m − 1, aicc and fpe are nan (as the contract's compute_metrics), not an error.
     */
    public static Metrics compute(double[][] tauMeas, double[][] tauPred, long nParams, int ddof) {
        // r2 first: it carries the minimum N of compute_metrics (2) and checks the data in the contract's order.
        MetricValue r2Pooled = Dynval.r2(tauMeas, tauPred, MultiOutput.POOLED);
        InformationCriteria ic = Dynval.criteriaImpl("criteria", tauMeas, tauPred, nParams, "pooled", "raise");
        double[][] e = Dynval.residuals(tauMeas, tauPred);
        return new Metrics(
                tauMeas.length,
                tauMeas[0].length,
                nParams,
                Dynval.sse(tauMeas, tauPred, MultiOutput.RAW_VALUES).values(),
                Dynval.rmse(tauMeas, tauPred, MultiOutput.RAW_VALUES).values(),
                Dynval.maxAbsError(tauMeas, tauPred, MultiOutput.RAW_VALUES).values(),
                Dynval.vaf(tauMeas, tauPred, MultiOutput.RAW_VALUES).values(),
                Dynval.fitPercent(tauMeas, tauPred, MultiOutput.RAW_VALUES).values(),
                Dynval.r2(tauMeas, tauPred, MultiOutput.RAW_VALUES).values(),
                Dynval.residualMean(e),
                Dynval.residualVariance(e, ddof),
                Dynval.sse(tauMeas, tauPred, MultiOutput.POOLED).value(),
                Dynval.rmse(tauMeas, tauPred, RmseConvention.PER_ELEMENT),
                Dynval.rmse(tauMeas, tauPred, RmseConvention.PER_SAMPLE),
                Dynval.maxAbsError(tauMeas, tauPred, MultiOutput.POOLED).value(),
                Dynval.vaf(tauMeas, tauPred, MultiOutput.POOLED).value(),
                Dynval.fitPercent(tauMeas, tauPred, MultiOutput.POOLED).value(),
                r2Pooled.value(),
                Dynval.rmse(tauMeas, tauPred, MultiOutput.UNIFORM_AVERAGE).value(),
                Dynval.vaf(tauMeas, tauPred, MultiOutput.UNIFORM_AVERAGE).value(),
                Dynval.fitPercent(tauMeas, tauPred, MultiOutput.UNIFORM_AVERAGE).value(),
                Dynval.r2(tauMeas, tauPred, MultiOutput.UNIFORM_AVERAGE).value(),
                Dynval.vaf(tauMeas, tauPred, MultiOutput.VARIANCE_WEIGHTED).value(),
                Dynval.fitPercent(tauMeas, tauPred, MultiOutput.VARIANCE_WEIGHTED).value(),
                Dynval.r2(tauMeas, tauPred, MultiOutput.VARIANCE_WEIGHTED).value(),
                ic.aic(),
                ic.bic(),
                ic.aicc(),
                ic.fpe(),
                ic.naic());
    }
}
