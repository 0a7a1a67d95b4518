package org.dynval;

/**
 * Zero-mean test of each joint's residual (contract §3.3): the i.i.d. Student t-test and the
 * test corrected for autocorrelation (Newey–West/Bartlett effective sample size), which is the
 * one to read on robot residuals. Arrays are per joint {@code (m,)}.
 */
public record ZeroMeanTest(
        double[] mean,
        double[] std,
        int nSamples,
        double[] statisticIid,
        double[] pvalueIid,
        int dfIid,
        double[] statisticEff,
        double[] pvalueEff,
        double[] dfEff,
        double[] nEff,
        int bandwidth) {
}
