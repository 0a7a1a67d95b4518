package org.dynval;

import static org.junit.jupiter.api.Assertions.assertArrayEquals;
import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertThrows;
import static org.junit.jupiter.api.Assertions.assertTrue;

import org.junit.jupiter.api.Test;

/** The typed API: values worked out by hand or quoted from the lesson and docs/contract.md. */
class DynvalTest {

    private static final double[][] MEAS = {{1.0, 2.0}, {2.0, 1.0}, {0.5, 3.0}};
    private static final double[][] PRED = {{1.5, 2.0}, {2.5, 0.5}, {0.0, 3.5}};

    private static double[][] column(double[] x) {
        double[][] out = new double[x.length][1];
        for (int i = 0; i < x.length; i++) {
            out[i][0] = x[i];
        }
        return out;
    }

    private static InputError rejects(ErrorKind kind, org.junit.jupiter.api.function.Executable call) {
        InputError error = assertThrows(InputError.class, call);
        assertEquals(kind, error.kind(), error.getMessage());
        return error;
    }

    // ------------------------------------------------------------------ the lesson's own example

    /** The lesson's scalar example (values of the lesson's Java and numpy code, docs build notes). */
    @Test
    void lessonScalarExample() {
        double[][] meas = column(new double[] {1.0, 2.5, 3.2, 4.1, 4.8, 6.1});
        double[][] pred = column(new double[] {1.1, 2.4, 3.0, 4.3, 4.7, 6.0});
        assertEquals(0.14142135623730953, Dynval.rmse(meas, pred, MultiOutput.POOLED).value(), 1e-15);
        assertEquals(99.29467897521003, Dynval.vaf(meas, pred, MultiOutput.POOLED).value(), 1e-12);
        assertEquals(-19.472138032568875, Dynval.aic(meas, pred, 2, NoiseModel.POOLED), 1e-12);
        assertEquals(-19.888619094112766, Dynval.bic(meas, pred, 2, NoiseModel.POOLED), 1e-12);
    }

    /** Lesson Problem 4 (golden/README.md): N = 1000, RSS 10 (p = 6) and 8.5 (p = 10). */
    @Test
    void lessonProblemFour() {
        InformationCriteria one = Dynval.informationCriteria(10.0, 1000, 6);
        InformationCriteria two = Dynval.informationCriteria(8.5, 1000, 10);
        assertEquals(-4593.170185988091, one.aic(), 1e-9);
        assertEquals(-4563.723654314199, one.bic(), 1e-9);
        assertEquals(-4747.689115485866, two.aic(), 1e-9);
        assertEquals(-4698.6115626960445, two.bic(), 1e-9);
    }

    // ------------------------------------------------------------------ point metrics

    @Test
    void pooledAndPerJointNorms() {
        double[][] meas = {{1.0, 2.0}, {3.0, 4.0}};
        double[][] pred = {{1.0, 1.0}, {3.0, 2.0}};
        assertEquals(5.0, Dynval.sse(meas, pred, MultiOutput.POOLED).value());
        assertArrayEquals(new double[] {0.0, 5.0}, Dynval.sse(meas, pred, MultiOutput.RAW_VALUES).values());
        assertEquals(2.0, Dynval.maxAbsError(meas, pred, MultiOutput.POOLED).value());
        assertArrayEquals(new double[] {0.0, 2.0}, Dynval.maxAbsError(meas, pred, MultiOutput.RAW_VALUES).values());
        assertEquals(Math.sqrt(5.0 / 4), Dynval.rmse(meas, pred, RmseConvention.PER_ELEMENT), 1e-15);
        assertEquals(Math.sqrt(5.0 / 2), Dynval.rmse(meas, pred, RmseConvention.PER_SAMPLE), 1e-15);
        assertArrayEquals(new double[] {0.0, Math.sqrt(2.5)}, Dynval.rmse(meas, pred, MultiOutput.RAW_VALUES).values(), 1e-15);
        assertEquals(Math.sqrt(2.5) / 2, Dynval.rmse(meas, pred, MultiOutput.UNIFORM_AVERAGE).value(), 1e-15);
    }

    @Test
    void normalizedFitByHand() {
        double[][] meas = column(new double[] {1.0, 2.0, 3.0});
        double[][] pred = column(new double[] {1.0, 2.0, 4.0});
        assertEquals(0.5, Dynval.r2(meas, pred, MultiOutput.POOLED).value(), 1e-15);
        assertEquals(100.0 * (1.0 - Math.sqrt(0.5)), Dynval.fitPercent(meas, pred, MultiOutput.POOLED).value(), 1e-13);
        // e = (0, 0, -1): centred sum of squares 2/3 against TSS 2.
        assertEquals(100.0 * (1.0 - 1.0 / 3.0), Dynval.vaf(meas, pred, MultiOutput.POOLED).value(), 1e-12);
    }

    @Test
    void aggregationsOverJoints() {
        double[] r2 = Dynval.r2(MEAS, PRED, MultiOutput.RAW_VALUES).values();
        double tss0 = 7.0 / 6.0; // joint 0 holds 1, 2, 0.5 (mean 7/6)
        double tss1 = 2.0; // joint 1 holds 2, 1, 3 (mean 2)
        double sse0 = 0.25 + 0.25 + 0.25;
        double sse1 = 0.0 + 0.25 + 0.25;
        assertEquals(1 - sse0 / tss0, r2[0], 1e-14);
        assertEquals(1 - sse1 / tss1, r2[1], 1e-14);
        assertEquals((r2[0] + r2[1]) / 2, Dynval.r2(MEAS, PRED, MultiOutput.UNIFORM_AVERAGE).value(), 1e-14);
        assertEquals(1 - (sse0 + sse1) / (tss0 + tss1), Dynval.r2(MEAS, PRED, MultiOutput.VARIANCE_WEIGHTED).value(), 1e-14);
    }

    @Test
    void oneDimensionalAndSingleColumnSignalsAgree() {
        double[] a = {1.0, 2.5, 3.2, 4.1};
        double[] b = {1.1, 2.4, 3.0, 4.3};
        Object[] forms = {a, column(a)};
        Object[] preds = {b, column(b)};
        double expected = Dynval.r2Impl(a, b, "pooled", "raise").value();
        for (Object x : forms) {
            for (Object y : preds) {
                assertEquals(expected, Dynval.r2Impl(x, y, "pooled", "raise").value());
                assertEquals(1, Dynval.r2Impl(x, y, "raw_values", "raise").values().length);
            }
        }
        assertArrayEquals(new double[] {-0.1, 0.1, 0.2, -0.2}, Dynval.residuals(a, b), 1e-15);
    }

    // ------------------------------------------------------------------ degenerate values (contract §3.2)

    @Test
    void constantTargetGivesMinusInfinityOrNan() {
        double[][] meas = {{2.0, 1.0}, {2.0, 2.0}, {2.0, 3.0}};
        double[][] pred = {{1.0, 1.0}, {2.0, 2.0}, {3.0, 3.0}};
        double[] r2 = Dynval.r2(meas, pred, MultiOutput.RAW_VALUES).values();
        assertEquals(Double.NEGATIVE_INFINITY, r2[0]);
        assertEquals(1.0, r2[1]);
        assertEquals(Double.NEGATIVE_INFINITY, Dynval.r2(meas, pred, MultiOutput.UNIFORM_AVERAGE).value());
        // the constant joint is left out of the weighted average
        assertEquals(1.0, Dynval.r2(meas, pred, MultiOutput.VARIANCE_WEIGHTED).value());
        double[][] exact = {{2.0}, {2.0}, {2.0}};
        assertTrue(Double.isNaN(Dynval.r2(exact, exact, MultiOutput.POOLED).value()));
        assertTrue(Double.isNaN(Dynval.vaf(exact, exact, MultiOutput.POOLED).value()));
        assertTrue(Double.isNaN(Dynval.fitPercent(exact, exact, MultiOutput.POOLED).value()));
    }

    @Test
    void exactFitGivesMinusInfinityCriteria() {
        InformationCriteria ic = Dynval.criteria(MEAS, MEAS, 1, NoiseModel.POOLED);
        assertEquals(Double.NEGATIVE_INFINITY, ic.aic());
        assertEquals(Double.NEGATIVE_INFINITY, ic.bic());
        assertEquals(Double.NEGATIVE_INFINITY, ic.aicc());
        assertEquals(0.0, ic.fpe());
    }

    @Test
    void tooManyParametersGiveNanAiccAndFpe() {
        InformationCriteria ic = Dynval.criteria(MEAS, PRED, 5, NoiseModel.POOLED); // n = 6, p = 5 >= n − 1
        assertTrue(Double.isNaN(ic.aicc()));
        assertTrue(Double.isNaN(ic.fpe()));
        assertTrue(Double.isFinite(ic.aic()));
    }

    @Test
    void noiseModels() {
        double[][] e = {{1.0, 0.5}, {-1.0, 0.5}, {2.0, -1.0}, {0.0, 1.0}};
        double[][] zero = new double[4][2];
        int n = 4;
        double v0 = (1 + 1 + 4 + 0) / 4.0;
        double v1 = (0.25 + 0.25 + 1 + 1) / 4.0;
        InformationCriteria perJoint = Dynval.criteria(e, zero, 1, NoiseModel.PER_JOINT);
        assertEquals(n * (Math.log(v0) + Math.log(v1)) + 2, perJoint.aic(), 1e-13);
        double c01 = (0.5 - 0.5 - 2.0 + 0.0) / 4.0;
        double det = v0 * v1 - c01 * c01;
        InformationCriteria full = Dynval.criteria(e, zero, 1, NoiseModel.FULL);
        assertEquals(n * Math.log(det) + 2, full.aic(), 1e-13);
        assertEquals(det * (1 + 0.25) / (1 - 0.25), full.fpe(), 1e-14);
        // a singular covariance (one joint a multiple of the other)
        double[][] singular = {{1.0, 2.0}, {-1.0, -2.0}, {3.0, 6.0}};
        assertEquals(Double.NEGATIVE_INFINITY, Dynval.criteria(singular, new double[3][2], 0, NoiseModel.FULL).aic());
    }

    @Test
    void symmetricEigenvalues() {
        assertArrayEquals(new double[] {1.0, 3.0}, Kernels.symmetricEigenvalues(new double[][] {{2, 1}, {1, 2}}), 1e-15);
        // [[4,1,0],[1,3,1],[0,1,2]]: eigenvalues 3 − √3, 3, 3 + √3
        double[] eig = Kernels.symmetricEigenvalues(new double[][] {{4, 1, 0}, {1, 3, 1}, {0, 1, 2}});
        assertArrayEquals(new double[] {3 - Math.sqrt(3), 3, 3 + Math.sqrt(3)}, eig, 1e-14);
    }

    // ------------------------------------------------------------------ residual statistics and correlation

    @Test
    void residualMeanAndVariance() {
        assertArrayEquals(new double[] {2.0, 0.5}, Dynval.residualMean(new double[][] {{1, 0}, {3, 1}}), 1e-15);
        assertArrayEquals(new double[] {1.0}, Dynval.residualVariance(column(new double[] {1, 2, 3}), 1), 1e-15);
        assertArrayEquals(new double[] {2.0 / 3}, Dynval.residualVariance(column(new double[] {1, 2, 3}), 0), 1e-15);
    }

    @Test
    void largeOffsetNeedsTwoPassSums() {
        // 1e9 + small noise: E[x²] − E[x]² would lose every digit of the variance.
        double[] x = {1e9 + 0.1, 1e9 - 0.2, 1e9 + 0.3, 1e9 - 0.2};
        double mean = 0.0;
        double[] d = new double[4];
        for (int i = 0; i < 4; i++) {
            d[i] = x[i] - 1e9; // exact for these values
            mean += d[i] / 4;
        }
        double ss = 0.0;
        for (double v : d) {
            ss += (v - mean) * (v - mean);
        }
        assertEquals(ss / 3, Dynval.residualVariance(column(x), 1)[0], 1e-12);
    }

    @Test
    void autocorrelationBiasedAndAdjusted() {
        double[][] e = column(new double[] {1.0, -1.0, 1.0, -1.0});
        double[][] rho = Dynval.autocorrelation(e, 1, false, null);
        assertEquals(1.0, rho[0][0]);
        assertEquals(-0.75, rho[1][0], 1e-15); // (−3/4) / (4/4)
        // adjusted: R(1) = −3/3 over R(0) = 4/4
        assertEquals(-1.0, Dynval.autocorrelation(new double[] {1.0, -1.0, 1.0, -1.0}, 1)[1], 1e-15);
        // a constant residual has no scale: nan at every lag
        double[] constant = Dynval.autocorrelation(new double[] {2.0, 2.0, 2.0}, 1);
        assertTrue(Double.isNaN(constant[0]) && Double.isNaN(constant[1]));
    }

    @Test
    void segmentsAsLengthsOrStartsAreTheSame() {
        double[][] e = column(new double[] {0.3, -1.2, 0.8, 0.1, -0.4, 1.5, -0.9});
        double[][] byLengths = Dynval.autocorrelation(e, 2, true, new int[] {3, 4});
        double[][] byStarts = Dynval.autocorrelation(e, 2, true, new int[] {0, 3});
        for (int i = 0; i < 3; i++) {
            assertArrayEquals(byLengths[i], byStarts[i]);
        }
    }

    @Test
    void omitDeletesRowsAndBreaksTheSegment() {
        double[] withNan = {1.0, 4.0, Double.NaN, 3.0, -2.0, 0.5};
        double[] kept = {1.0, 4.0, 3.0, -2.0, 0.5};
        double[][] omitted = Dynval.autocorrelationImpl(withNan, 1L, true, null, "omit");
        double[][] segmented = Dynval.autocorrelation(column(kept), 1, true, new int[] {2, 3});
        assertEquals(segmented[1][0], omitted[1][0], 1e-15);
        assertTrue(Math.abs(segmented[1][0] - Dynval.autocorrelation(kept, 1)[1]) > 1e-3);
    }

    @Test
    void omitThroughTheTypedApi() {
        double[][] meas = {{1.0, 2.0}, {Double.NaN, 1.0}, {2.0, 1.5}, {0.5, 3.0}};
        double[][] pred = {{1.5, 2.0}, {2.5, 0.5}, {2.5, Double.POSITIVE_INFINITY}, {0.0, 3.5}};
        double[][] keptMeas = {{1.0, 2.0}, {0.5, 3.0}};
        double[][] keptPred = {{1.5, 2.0}, {0.0, 3.5}};
        assertEquals(Dynval.sse(keptMeas, keptPred, MultiOutput.POOLED).value(),
                Dynval.sse(meas, pred, MultiOutput.POOLED, NanPolicy.OMIT).value());
        rejects(ErrorKind.NON_FINITE_INPUT, () -> Dynval.sse(meas, pred, MultiOutput.POOLED, NanPolicy.RAISE));
        // two rows left, but the deleted rows split them: no lag-1 product remains, so max_lag 1 is out of range
        double[][] e = {{1.0, 2.0}, {Double.NaN, 1.0}, {2.0, Double.POSITIVE_INFINITY}, {0.5, 3.0}};
        rejects(ErrorKind.INVALID_PARAMETER, () -> Dynval.autocorrelation(e, 1, true, null, NanPolicy.OMIT));
        assertEquals(1.0, Dynval.autocorrelation(e, 0, true, null, NanPolicy.OMIT)[0][0]);
    }

    @Test
    void portmanteauByHand() {
        double[][] e = column(new double[] {1.0, -1.0, 1.0, -1.0});
        PortmanteauTest bp = Dynval.boxPierce(e, new int[] {1}, 0, null);
        assertEquals(2.25, bp.statistic()[0][0], 1e-14); // 4 · 0.75²
        assertEquals(Special.chi2Sf(2.25, 1), bp.pvalue()[0][0]);
        PortmanteauTest lb = Dynval.ljungBox(e, new int[] {1, 2}, 0, null);
        assertArrayEquals(new int[] {1, 2}, lb.df());
        assertEquals(4.0 * 6.0 * (0.5625 / 3), lb.statistic()[0][0], 1e-13); // N(N+2) ρ₁²/(N−1)
    }

    @Test
    void crossCorrelationOfASignalWithItself() {
        double[] e = {1.0, -1.0, 2.0, 0.0};
        double[][][] y = {{{1.0, 5.0}}, {{-1.0, 5.0}}, {{2.0, 5.0}}, {{0.0, 5.0}}};
        CrossCorrelation cc = Dynval.crossCorrelation(column(e), y, 1, true, 0.95, null);
        assertEquals(1.0, cc.rho()[0][0][0], 1e-15);
        assertTrue(cc.constantMask()[0][1]);
        assertTrue(Double.isNaN(cc.rho()[0][1][0]));
        assertEquals(1.9599639845400538 / 2.0, cc.band(), 1e-15);
    }

    @Test
    void confidenceBand() {
        assertEquals(0.19599639845400538, Dynval.confidenceBand(100, 0.95), 1e-15);
    }

    // ------------------------------------------------------------------ errors: kinds and exact messages

    @Test
    void messagesAreTheContractsTexts() {
        assertEquals("tau_meas must be 1-D (N,) or 2-D (N, m), got shape (2, 2, 1)",
                rejects(ErrorKind.INVALID_SHAPE, () -> Dynval.r2Impl(new double[][][] {{{1}, {2}}, {{3}, {4}}}, MEAS, "pooled",
                        "raise")).getMessage());
        assertEquals("tau_meas must have at least one column, got shape (3, 0)",
                rejects(ErrorKind.INVALID_SHAPE, () -> Dynval.r2(new double[3][0], new double[3][0], MultiOutput.POOLED))
                        .getMessage());
        assertEquals("tau_meas and tau_pred must have the same shape, got (3, 2) and (2, 2)",
                rejects(ErrorKind.SHAPE_MISMATCH, () -> Dynval.r2(MEAS, new double[2][2], MultiOutput.POOLED)).getMessage());
        assertEquals("r2 needs at least 2 samples, got N=1",
                rejects(ErrorKind.TOO_FEW_SAMPLES, () -> Dynval.r2(new double[1][2], new double[1][2], MultiOutput.POOLED))
                        .getMessage());
        assertEquals("tau_pred has a non-finite value (-inf) at row 2, column 1",
                rejects(ErrorKind.NON_FINITE_INPUT, () -> Dynval.r2(MEAS,
                        new double[][] {{1, 2}, {2, 1}, {0.5, Double.NEGATIVE_INFINITY}}, MultiOutput.POOLED)).getMessage());
        assertEquals("tau_pred has a value out of range (-3e+200) at row 1, column 1: |x| must be at most 1e+144",
                rejects(ErrorKind.NON_FINITE_INPUT, () -> Dynval.sse(MEAS,
                        new double[][] {{1, 2}, {2, -3e200}, {0.5, 3}}, MultiOutput.POOLED)).getMessage());
        assertEquals("multioutput must be one of 'pooled', 'raw_values' for sse, got 'uniform_average'",
                rejects(ErrorKind.INVALID_PARAMETER, () -> Dynval.sse(MEAS, PRED, MultiOutput.UNIFORM_AVERAGE)).getMessage());
        assertEquals("max_lag must be an integer with 0 <= max_lag < 3, got 3",
                rejects(ErrorKind.INVALID_PARAMETER, () -> Dynval.autocorrelation(MEAS, 3, true, null)).getMessage());
        assertEquals("n_params must be less than n_obs - 1 = 9, got 9",
                rejects(ErrorKind.INVALID_PARAMETER, () -> Dynval.informationCriteria(1.0, 10, 9)).getMessage());
        assertEquals("segments must be positive lengths summing to N=3, or increasing starts beginning at 0 and below N=3, got [2, 2]",
                rejects(ErrorKind.INVALID_PARAMETER, () -> Dynval.autocorrelation(MEAS, 1, true, new int[] {2, 2})).getMessage());
    }

    @Test
    void exactlyTheRangeLimitIsAccepted() {
        double[][] meas = column(new double[] {1e144, -1e144, 0.0});
        assertEquals(2e288, Dynval.sse(meas, new double[3][1], MultiOutput.POOLED).value(), 1e274);
    }

    @Test
    void raggedRowsAreInvalidType() {
        rejects(ErrorKind.INVALID_TYPE, () -> Dynval.r2(new double[][] {{1, 2}, {3}}, MEAS, MultiOutput.POOLED));
    }
}
