package org.dynval;

/**
 * Ljung–Box or Box–Pierce statistics (contract §3.5): {@code statistic}, {@code pvalue} and
 * {@code logPvalue} are {@code [nLags][m]}; {@code lags} and {@code df} have one entry per lag.
 * {@code logPvalue} stays finite where {@code pvalue} underflows to 0.
 */
public record PortmanteauTest(
        String test,
        int[] lags,
        int modelDf,
        double[][] statistic,
        double[][] pvalue,
        double[][] logPvalue,
        int[] df) {
}
