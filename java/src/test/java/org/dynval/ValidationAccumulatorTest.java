package org.dynval;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertNotEquals;
import static org.junit.jupiter.api.Assertions.assertNull;
import static org.junit.jupiter.api.Assertions.assertThrows;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.util.ArrayList;
import java.util.Arrays;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.Random;
import org.junit.jupiter.api.Test;

/**
 * The streaming accumulator against the in-memory functions on the same rows: however the rows
 * are chunked, broken into records and merged, the result must be the in-memory value.
 */
class ValidationAccumulatorTest {

    /** Rows of a model test: a target, a prediction whose residual is coloured, and a regressor. */
    private record Data(double[][] meas, double[][] pred, double[][][] reg) {
        int n() {
            return meas.length;
        }

        double[][] meas(int a, int b) {
            return Arrays.copyOfRange(meas, a, b);
        }

        double[][] pred(int a, int b) {
            return Arrays.copyOfRange(pred, a, b);
        }

        double[][][] reg(int a, int b) {
            return reg == null ? null : Arrays.copyOfRange(reg, a, b);
        }
    }

    private static Data data(long seed, int n, int m, int p, double offset) {
        Random rng = new Random(seed);
        double[][] meas = new double[n][m];
        double[][] pred = new double[n][m];
        double[][][] reg = p == 0 ? null : new double[n][m][p];
        double[] e = new double[m];
        for (int k = 0; k < n; k++) {
            for (int j = 0; j < m; j++) {
                // AR(1) residuals with a mean: the lagged products are far from zero, so a lost
                // or doubled product across a junction shows in the autocorrelation
                e[j] = 0.7 * e[j] + 0.1 * rng.nextGaussian();
                meas[k][j] = offset + (j + 1) * Math.sin(0.05 * k + j) + 0.3 * rng.nextGaussian();
                pred[k][j] = meas[k][j] - e[j] - 0.02 * (j + 1);
                for (int c = 0; c < p; c++) {
                    reg[k][j][c] = Math.cos(0.07 * k * (c + 1) + j) + 0.5 * rng.nextGaussian() + 3.0 * c;
                }
            }
        }
        return new Data(meas, pred, reg);
    }

    /** Random block lengths summing to n, many of them shorter than maxLag (down to one row). */
    private static int[] randomBlocks(Random rng, int n, int maxLag) {
        List<Integer> out = new ArrayList<>();
        int left = n;
        while (left > 0) {
            int len = rng.nextInt(4) == 0 ? 1 + rng.nextInt(3 * maxLag + 40) : 1 + rng.nextInt(maxLag);
            len = Math.min(len, left);
            out.add(len);
            left -= len;
        }
        return out.stream().mapToInt(Integer::intValue).toArray();
    }

    private static void close(double[] want, double[] got, double tol, String what) {
        assertEquals(want.length, got.length, what);
        double scale = 1.0;
        for (double w : want) {
            if (Double.isFinite(w)) {
                scale = Math.max(scale, Math.abs(w));
            }
        }
        for (int i = 0; i < want.length; i++) {
            if (Double.isNaN(want[i]) || Double.isInfinite(want[i])) {
                assertEquals(want[i], got[i], what + "[" + i + "]");
            } else {
                assertEquals(want[i], got[i], tol * scale, what + "[" + i + "]");
            }
        }
    }

    private static void close(double[][] want, double[][] got, double tol, String what) {
        assertEquals(want.length, got.length, what);
        for (int i = 0; i < want.length; i++) {
            close(want[i], got[i], tol, what + "[" + i + "]");
        }
    }

    /** Every output of the accumulator equals the in-memory function on the whole series. */
    private static void assertMatchesInMemory(Data d, int[] segments, int maxLag, long nParams, NoiseModel model,
            ValidationAccumulator.Metrics got) {
        double tol = 1e-12;
        double[][] e = Dynval.residuals(d.meas(), d.pred());
        assertEquals(d.n(), got.nSamples());
        close(Dynval.sse(d.meas(), d.pred(), MultiOutput.RAW_VALUES).values(), got.sse(), tol, "sse");
        close(Dynval.rmse(d.meas(), d.pred(), MultiOutput.RAW_VALUES).values(), got.rmse(), tol, "rmse");
        close(Dynval.maxAbsError(d.meas(), d.pred(), MultiOutput.RAW_VALUES).values(), got.maxAbsError(), tol,
                "max_abs_error");
        close(Dynval.vaf(d.meas(), d.pred(), MultiOutput.RAW_VALUES).values(), got.vaf(), tol, "vaf");
        close(Dynval.fitPercent(d.meas(), d.pred(), MultiOutput.RAW_VALUES).values(), got.fitPercent(), tol, "fit");
        close(Dynval.r2(d.meas(), d.pred(), MultiOutput.RAW_VALUES).values(), got.r2(), tol, "r2");
        close(Dynval.residualMean(e), got.residualMean(), tol, "residual_mean");
        close(Dynval.residualVariance(e, 1), got.residualVariance(), tol, "residual_variance");
        close(Dynval.autocorrelation(e, maxLag, true, segments), got.autocorrelation(), tol, "autocorrelation");
        if (d.reg() == null) {
            assertNull(got.rho());
        } else {
            double[][][] rho = Dynval.crossCorrelation(e, d.reg(), maxLag, true, 0.95, segments).rho();
            for (int j = 0; j < rho.length; j++) {
                close(rho[j], got.rho()[j], tol, "rho[" + j + "]");
            }
        }
        InformationCriteria want = Dynval.criteria(d.meas(), d.pred(), nParams, model);
        InformationCriteria ic = got.criteria();
        close(new double[] {want.aic(), want.bic(), want.aicc(), want.fpe(), want.naic()},
                new double[] {ic.aic(), ic.bic(), ic.aicc(), ic.fpe(), ic.naic()}, tol, "criteria " + model);
        assertEquals(want.nObs(), ic.nObs());
    }

    private static ValidationAccumulator block(Data d, int a, int b, int maxLag, NoiseModel model) {
        ValidationAccumulator acc = new ValidationAccumulator(6, maxLag, model);
        acc.update(d.meas(a, b), d.pred(a, b), d.reg(a, b));
        return acc;
    }

    private static List<ValidationAccumulator> blocks(Data d, int[] lengths, int maxLag, NoiseModel model) {
        List<ValidationAccumulator> out = new ArrayList<>();
        int a = 0;
        for (int len : lengths) {
            out.add(block(d, a, a + len, maxLag, model));
            a += len;
        }
        return out;
    }

    private static ValidationAccumulator left(List<ValidationAccumulator> parts) {
        ValidationAccumulator out = parts.get(0);
        for (ValidationAccumulator acc : parts.subList(1, parts.size())) {
            out = out.merge(acc);
        }
        return out;
    }

    private static ValidationAccumulator right(List<ValidationAccumulator> parts) {
        ValidationAccumulator out = parts.get(parts.size() - 1);
        for (int i = parts.size() - 2; i >= 0; i--) {
            out = parts.get(i).merge(out);
        }
        return out;
    }

    private static ValidationAccumulator tree(List<ValidationAccumulator> parts) {
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

    private static List<ValidationAccumulator> copies(List<ValidationAccumulator> parts) {
        List<ValidationAccumulator> out = new ArrayList<>();
        for (ValidationAccumulator acc : parts) {
            out.add(acc.copy());
        }
        return out;
    }

    // ------------------------------------------------------------------ chunking and merging

    /** One accumulator fed random chunks (one row, fewer rows than maxLag, longer) across its block buffer. */
    @Test
    void randomChunksOfOneAccumulatorEqualInMemory() {
        Random rng = new Random(11);
        for (int trial = 0; trial < 4; trial++) {
            int maxLag = 3 + 4 * trial;
            Data d = data(100 + trial, 700 + 37 * trial, 3, 2, 0.0);
            ValidationAccumulator acc = new ValidationAccumulator(6, maxLag, NoiseModel.POOLED);
            int a = 0;
            for (int len : randomBlocks(rng, d.n(), maxLag)) {
                acc.update(d.meas(a, a + len), d.pred(a, a + len), d.reg(a, a + len));
                a += len;
            }
            assertMatchesInMemory(d, null, maxLag, 6, NoiseModel.POOLED, acc.result());
        }
    }

    /** Blocks of 1..maxLag rows (and some longer), one accumulator each, in all four merge orders. */
    @Test
    void everyMergeOrderOfShortBlocksEqualsInMemory() {
        Random rng = new Random(12);
        int maxLag = 9;
        for (NoiseModel model : NoiseModel.values()) {
            Data d = data(200 + model.ordinal(), 160, 3, 2, 0.0);
            int[] lengths = randomBlocks(rng, d.n(), maxLag);
            List<ValidationAccumulator> parts = blocks(d, lengths, maxLag, model);
            assertMatchesInMemory(d, null, maxLag, 6, model, left(copies(parts)).result());
            assertMatchesInMemory(d, null, maxLag, 6, model, right(copies(parts)).result());
            assertMatchesInMemory(d, null, maxLag, 6, model, tree(copies(parts)).result());
            ValidationAccumulator none = new ValidationAccumulator(6, maxLag, model);
            int a = 0;
            for (int len : lengths) {
                none.update(d.meas(a, a + len), d.pred(a, a + len), d.reg(a, a + len));
                a += len;
            }
            assertMatchesInMemory(d, null, maxLag, 6, model, none.result());
        }
    }

    /** Forty one-row accumulators merged pairwise: every lagged product crosses a junction. */
    @Test
    void oneRowBlocksMergedPairwise() {
        Data d = data(3, 40, 2, 1, 0.0);
        int[] ones = new int[40];
        Arrays.fill(ones, 1);
        assertMatchesInMemory(d, null, 5, 6, NoiseModel.PER_JOINT,
                tree(blocks(d, ones, 5, NoiseModel.PER_JOINT)).result());
    }

    @Test
    void mergeLeavesItsArgumentUnchangedAndCopiesAreIndependent() {
        Data d = data(4, 90, 2, 1, 0.0);
        ValidationAccumulator a = block(d, 0, 50, 4, NoiseModel.POOLED);
        ValidationAccumulator b = block(d, 50, 90, 4, NoiseModel.POOLED);
        double[][] before = b.result().autocorrelation();
        ValidationAccumulator snapshot = a.copy();
        a.merge(b);
        close(before, b.result().autocorrelation(), 0.0, "b after the merge");
        assertEquals(40, b.nSamples());
        assertEquals(50, snapshot.nSamples());
        assertMatchesInMemory(d, null, 4, 6, NoiseModel.POOLED, a.result());
        Data first = new Data(d.meas(0, 50), d.pred(0, 50), d.reg(0, 50));
        assertMatchesInMemory(first, null, 4, 6, NoiseModel.POOLED, snapshot.result());
    }

    /** A stream an accumulator merges into itself is the series twice, end to end. */
    @Test
    void mergingWithItselfDoublesTheSeries() {
        Data d = data(5, 30, 2, 0, 0.0);
        ValidationAccumulator acc = block(d, 0, 30, 3, NoiseModel.POOLED);
        acc.merge(acc);
        double[][] meas = new double[60][];
        double[][] pred = new double[60][];
        for (int k = 0; k < 60; k++) {
            meas[k] = d.meas()[k % 30];
            pred[k] = d.pred()[k % 30];
        }
        assertMatchesInMemory(new Data(meas, pred, null), null, 3, 6, NoiseModel.POOLED, acc.result());
    }

    // ------------------------------------------------------------------ records

    /**
     * Records of 37, 45 and 38 rows: a break inside a block (between two updates), a break at a
     * junction (the later block starts the record), and a break at the end of the earlier block.
     */
    @Test
    void breaksInsideBlocksAndAtJunctions() {
        int maxLag = 7;
        Data d = data(6, 120, 2, 2, 0.0);
        int[] segments = {37, 45, 38};
        // blocks [0, 50) with the break at 37 inside; [50, 82); [82, 120) starting the third record
        ValidationAccumulator a = new ValidationAccumulator(6, maxLag, NoiseModel.FULL);
        a.update(d.meas(0, 37), d.pred(0, 37), d.reg(0, 37));
        a.breakSegment();
        a.update(d.meas(37, 50), d.pred(37, 50), d.reg(37, 50));
        ValidationAccumulator b = block(d, 50, 82, maxLag, NoiseModel.FULL);
        ValidationAccumulator c = new ValidationAccumulator(6, maxLag, NoiseModel.FULL);
        c.breakSegment();
        c.update(d.meas(82, 120), d.pred(82, 120), d.reg(82, 120));
        List<ValidationAccumulator> parts = List.of(a, b, c);
        assertMatchesInMemory(d, segments, maxLag, 6, NoiseModel.FULL, left(copies(parts)).result());
        assertMatchesInMemory(d, segments, maxLag, 6, NoiseModel.FULL, right(copies(parts)).result());
        assertMatchesInMemory(d, segments, maxLag, 6, NoiseModel.FULL, tree(copies(parts)).result());

        // the break at 82 as the end of the earlier block instead of the start of the later one
        ValidationAccumulator b2 = block(d, 50, 82, maxLag, NoiseModel.FULL);
        b2.breakSegment();
        ValidationAccumulator c2 = block(d, 82, 120, maxLag, NoiseModel.FULL);
        assertMatchesInMemory(d, segments, maxLag, 6, NoiseModel.FULL,
                a.copy().merge(b2).merge(c2).result());

        // without any break the products join: the in-memory value on one record, not on three
        ValidationAccumulator joined = left(blocks(d, new int[] {50, 32, 38}, maxLag, NoiseModel.FULL));
        assertMatchesInMemory(d, null, maxLag, 6, NoiseModel.FULL, joined.result());
        assertNotEquals(Dynval.autocorrelation(Dynval.residuals(d.meas(), d.pred()), maxLag, true, segments)[1][0],
                joined.result().autocorrelation()[1][0]);
    }

    /** Records shorter than maxLag on either side of a merge, and repeated breaks making no empty record. */
    @Test
    void shortRecordsAndRepeatedBreaks() {
        int maxLag = 6;
        Data d = data(7, 40, 1, 1, 0.0);
        ValidationAccumulator a = new ValidationAccumulator(6, maxLag, NoiseModel.POOLED);
        a.breakSegment();
        a.update(d.meas(0, 3), d.pred(0, 3), d.reg(0, 3));
        a.breakSegment();
        a.breakSegment();
        a.update(d.meas(3, 20), d.pred(3, 20), d.reg(3, 20));
        ValidationAccumulator b = new ValidationAccumulator(6, maxLag, NoiseModel.POOLED);
        b.update(d.meas(20, 22), d.pred(20, 22), d.reg(20, 22));
        b.breakSegment();
        b.update(d.meas(22, 40), d.pred(22, 40), d.reg(22, 40));
        assertMatchesInMemory(d, new int[] {3, 19, 18}, maxLag, 6, NoiseModel.POOLED, a.merge(b).result());
    }

    // ------------------------------------------------------------------ accuracy and size

    /** Torques on a 1e7 offset with residuals of 0.01: centred sums keep the in-memory digits. */
    @Test
    void largeOffsetKeepsItsDigits() {
        Data d = data(8, 400, 2, 1, 1e7);
        int maxLag = 5;
        List<ValidationAccumulator> parts = blocks(d, randomBlocks(new Random(13), d.n(), maxLag), maxLag,
                NoiseModel.POOLED);
        ValidationAccumulator.Metrics got = tree(parts).result();
        assertMatchesInMemory(d, null, maxLag, 6, NoiseModel.POOLED, got);
        // the spread of the target (about 1) is 1e-7 of its level: E[x²] − E[x]² would lose it all
        double[] r2 = Dynval.r2(d.meas(), d.pred(), MultiOutput.RAW_VALUES).values();
        close(r2, got.r2(), 1e-9, "r2");
    }

    /** The state after a million rows holds as many numbers as after a thousand. */
    @Test
    void stateDoesNotGrowWithTheRows() {
        int m = 2;
        int maxLag = 5;
        ValidationAccumulator acc = new ValidationAccumulator(3, maxLag, NoiseModel.PER_JOINT);
        double[][] meas = new double[1000][m];
        double[][] pred = new double[1000][m];
        double[][][] reg = new double[1000][m][1];
        long afterThousand = 0;
        for (int chunk = 0; chunk < 1000; chunk++) {
            for (int i = 0; i < 1000; i++) {
                double t = chunk * 1000.0 + i;
                for (int j = 0; j < m; j++) {
                    meas[i][j] = Math.sin(1e-3 * t + j);
                    pred[i][j] = meas[i][j] - 0.01 * Math.cos(0.3 * t * (j + 1));
                    reg[i][j][0] = Math.cos(2e-3 * t);
                }
            }
            acc.update(meas, pred, reg);
            if (chunk == 0) {
                afterThousand = acc.retainedValues();
            }
        }
        assertEquals(1_000_000, acc.nSamples());
        assertEquals(afterThousand, acc.retainedValues());
        assertTrue(afterThousand < 10_000, "retained " + afterThousand);
        // e = 0.01 cos(0.3 t (j + 1)): its mean square is 0.5e-4 over a million rows
        ValidationAccumulator.Metrics r = acc.result();
        assertEquals(0.5e-4, r.sse()[0] / 1e6, 1e-8);
        assertEquals(Math.cos(0.3), r.autocorrelation()[1][0], 1e-5);
    }

    // ------------------------------------------------------------------ degenerate values

    /** A constant target and a zero residual give the in-memory degenerate values (nan, −inf). */
    @Test
    void constantSeriesGiveTheInMemoryDegenerateValues() {
        double[][] meas = new double[12][2];
        double[][] pred = new double[12][2];
        for (int k = 0; k < 12; k++) {
            meas[k][0] = 2.5;
            pred[k][0] = 2.5 + (k % 3 == 0 ? 0.1 : -0.05);
            meas[k][1] = k;
            pred[k][1] = k;
        }
        Data d = new Data(meas, pred, null);
        ValidationAccumulator acc = block(d, 0, 5, 2, NoiseModel.POOLED).merge(block(d, 5, 12, 2, NoiseModel.POOLED));
        assertMatchesInMemory(d, null, 2, 6, NoiseModel.POOLED, acc.result());
        assertEquals(Double.NEGATIVE_INFINITY, acc.result().r2()[0]);
        assertTrue(Double.isNaN(acc.result().autocorrelation()[1][1]));
    }

    // ------------------------------------------------------------------ errors

    private static InputError rejects(ErrorKind kind, org.junit.jupiter.api.function.Executable call) {
        InputError error = assertThrows(InputError.class, call);
        assertEquals(kind, error.kind(), error.getMessage());
        return error;
    }

    @Test
    void settingsAreChecked() {
        assertEquals("max_lag must be an integer with max_lag >= 0, got -1",
                rejects(ErrorKind.INVALID_PARAMETER, () -> new ValidationAccumulator(1, -1, NoiseModel.POOLED))
                        .getMessage());
        assertEquals("n_params must be an integer with n_params >= 0, got -2",
                rejects(ErrorKind.INVALID_PARAMETER, () -> new ValidationAccumulator(-2, 1, NoiseModel.POOLED))
                        .getMessage());
        rejects(ErrorKind.INVALID_PARAMETER, () -> new ValidationAccumulator(1, 1, null));
    }

    @Test
    void chunksAreCheckedAndARejectedChunkChangesNothing() {
        Data d = data(9, 20, 2, 1, 0.0);
        ValidationAccumulator acc = new ValidationAccumulator(1, 2, NoiseModel.POOLED);
        acc.update(d.meas(0, 5), d.pred(0, 5), d.reg(0, 5));
        acc.update(d.meas(5, 8), d.pred(5, 8), d.reg(5, 8));
        double[][] before = acc.result().autocorrelation();

        assertEquals("chunk 2: tau_meas must have m=2 columns like the chunks before it, got shape (2, 3)",
                rejects(ErrorKind.SHAPE_MISMATCH, () -> acc.update(new double[2][3], new double[2][3],
                        new double[2][3][1])).getMessage());
        assertEquals("chunk 2: regressor must be given with every chunk or with none; the chunks before it had one",
                rejects(ErrorKind.SHAPE_MISMATCH, () -> acc.update(d.meas(8, 10), d.pred(8, 10))).getMessage());
        assertEquals("chunk 2: regressor must have p=1 columns like the chunks before it, got shape (2, 2, 3)",
                rejects(ErrorKind.SHAPE_MISMATCH, () -> acc.update(d.meas(8, 10), d.pred(8, 10),
                        new double[2][2][3])).getMessage());
        rejects(ErrorKind.SHAPE_MISMATCH, () -> acc.update(d.meas(8, 10), d.pred(8, 11), d.reg(8, 10)));
        rejects(ErrorKind.INVALID_TYPE, () -> acc.update(null, d.pred(8, 10), d.reg(8, 10)));
        double[][] bad = d.pred(8, 11);
        bad[1] = new double[] {bad[1][0], Double.NaN};
        assertEquals("chunk 2: tau_pred has a non-finite value (nan) at row 1, column 1 (row 9 of the stream)",
                rejects(ErrorKind.NON_FINITE_INPUT, () -> acc.update(d.meas(8, 11), bad, d.reg(8, 11))).getMessage());

        assertEquals(8, acc.nSamples());
        close(before, acc.result().autocorrelation(), 0.0, "after rejected chunks");
        acc.update(d.meas(8, 20), d.pred(8, 20), d.reg(8, 20));
        assertMatchesInMemory(d, null, 2, 1, NoiseModel.POOLED, acc.result());
    }

    @Test
    void resultNeedsTwoRowsAndMaxLagBelowTheLongestRecord() {
        ValidationAccumulator acc = new ValidationAccumulator(1, 3, NoiseModel.POOLED);
        assertEquals("ValidationAccumulator.result needs at least 2 samples, got N=0",
                rejects(ErrorKind.TOO_FEW_SAMPLES, acc::result).getMessage());
        acc.update(new double[] {1.0, 2.0, 3.0}, new double[] {1.1, 2.0, 2.9});
        acc.breakSegment();
        acc.update(new double[] {4.0, 5.0, 6.0}, new double[] {4.0, 5.2, 6.1});
        assertEquals("max_lag must be an integer with 0 <= max_lag < 3, got 3",
                rejects(ErrorKind.INVALID_PARAMETER, acc::result).getMessage());
        acc.update(new double[] {7.0}, new double[] {7.1});
        assertEquals(7, acc.nSamples());
        assertEquals(4, acc.result().autocorrelation().length); // the last record now has 4 rows
    }

    @Test
    void mergeNeedsTheSameSettingsAndShape() {
        ValidationAccumulator a = new ValidationAccumulator(1, 2, NoiseModel.POOLED);
        a.update(new double[3][2], new double[3][2]);
        assertEquals("other must be a ValidationAccumulator with the same settings, got max_lag=3 where this one "
                + "has max_lag=2", rejects(ErrorKind.INVALID_PARAMETER,
                        () -> a.merge(new ValidationAccumulator(1, 3, NoiseModel.POOLED))).getMessage());
        assertEquals("other must be a ValidationAccumulator with the same settings, got noise_model='full' where "
                + "this one has noise_model='pooled'", rejects(ErrorKind.INVALID_PARAMETER,
                        () -> a.merge(new ValidationAccumulator(1, 2, NoiseModel.FULL))).getMessage());
        ValidationAccumulator b = new ValidationAccumulator(1, 2, NoiseModel.POOLED);
        b.update(new double[3][3], new double[3][3]);
        assertEquals("other must hold data of the same shape, got m=3 joints and p=0 regressor columns where this "
                + "one has m=2 and p=0", rejects(ErrorKind.SHAPE_MISMATCH, () -> a.merge(b)).getMessage());
        assertEquals(3, a.nSamples());
    }

    // ------------------------------------------------------------------ the corpus driver

    private static Map<String, Operations.Output> accumulate(Data d, Object chunks, Object merge, Object segments,
            Object maxLag) {
        Map<String, Object> inputs = new LinkedHashMap<>();
        inputs.put("tau_meas", d.meas());
        inputs.put("tau_pred", d.pred());
        if (d.reg() != null) {
            inputs.put("regressor", d.reg());
        }
        inputs.put("n_params", 4L);
        inputs.put("max_lag", maxLag);
        Map<String, Object> conventions = new LinkedHashMap<>();
        conventions.put("chunks", chunks);
        conventions.put("merge", merge);
        conventions.put("segments", segments);
        conventions.put("noise_model", "pooled");
        conventions.put("nan_policy", "raise");
        return Operations.run("accumulate", inputs, conventions);
    }

    @Test
    void driverSplitsBlocksAtRecordStartsForEveryMerge() {
        Data d = data(10, 40, 2, 1, 0.0);
        double[][] e = Dynval.residuals(d.meas(), d.pred());
        int[] segments = {15, 25};
        double[][] want = Dynval.autocorrelation(e, 6, true, segments);
        for (String merge : List.of("none", "left", "right", "tree")) {
            // 15 starts a block, and in the second chunking it falls inside one
            for (List<Long> chunks : List.of(List.of(10L, 5L, 12L, 13L), List.of(9L, 22L, 9L))) {
                Operations.Output acf = accumulate(d, chunks, merge, List.of(15L, 25L), 6L).get("autocorrelation");
                assertEquals(List.of(7, 2), List.of(acf.shape()[0], acf.shape()[1]));
                for (int l = 0; l <= 6; l++) {
                    for (int j = 0; j < 2; j++) {
                        assertEquals(want[l][j], acf.values()[l * 2 + j], 1e-12, merge + " " + chunks);
                    }
                }
            }
        }
    }

    @Test
    void driverChecksItsParametersInTheContractOrder() {
        Data d = data(11, 40, 2, 0, 0.0);
        List<Long> ok = List.of(7L, 1L, 13L, 19L);
        assertEquals("chunks must be a non-empty list of positive lengths summing to N=40, got [7, 1, 13, 18]",
                rejects(ErrorKind.INVALID_PARAMETER,
                        () -> accumulate(d, List.of(7L, 1L, 13L, 18L), "left", null, 5L)).getMessage());
        rejects(ErrorKind.INVALID_PARAMETER, () -> accumulate(d, List.of(7L, 0L, 14L, 19L), "left", null, 5L));
        rejects(ErrorKind.INVALID_PARAMETER, () -> accumulate(d, null, "left", null, 5L));
        rejects(ErrorKind.INVALID_PARAMETER, () -> accumulate(d, List.of(), "left", null, 5L));
        rejects(ErrorKind.INVALID_PARAMETER, () -> accumulate(d, List.of(40.0), "left", null, 5L));
        assertEquals("merge must be one of 'none', 'left', 'right', 'tree', got 'sideways'",
                rejects(ErrorKind.INVALID_PARAMETER, () -> accumulate(d, ok, "sideways", null, 5L)).getMessage());
        rejects(ErrorKind.INVALID_PARAMETER, () -> accumulate(d, ok, "left", List.of(15L, 26L), 5L));
        assertEquals("max_lag must be an integer with 0 <= max_lag < 25, got 25",
                rejects(ErrorKind.INVALID_PARAMETER,
                        () -> accumulate(d, ok, "left", List.of(15L, 25L), 25L)).getMessage());
        // chunks before merge before max_lag; the data before every parameter
        assertTrue(rejects(ErrorKind.INVALID_PARAMETER,
                () -> accumulate(d, List.of(1L), "sideways", null, 99L)).getMessage().startsWith("chunks"));
        assertTrue(rejects(ErrorKind.INVALID_PARAMETER,
                () -> accumulate(d, ok, "sideways", null, 99L)).getMessage().startsWith("merge"));
        d.pred()[39][1] = Double.NaN;
        rejects(ErrorKind.NON_FINITE_INPUT, () -> accumulate(d, List.of(1L), "sideways", null, 99L));
    }

    @Test
    void driverRejectsARegressorOfOtherRowsAndOmit() {
        Data d = data(12, 40, 2, 2, 0.0);
        Data shorter = new Data(d.meas(), d.pred(), d.reg(0, 39));
        rejects(ErrorKind.SHAPE_MISMATCH, () -> accumulate(shorter, List.of(40L), "none", null, 5L));
        Map<String, Object> inputs = new LinkedHashMap<>();
        inputs.put("tau_meas", d.meas());
        inputs.put("tau_pred", d.pred());
        inputs.put("n_params", 4L);
        inputs.put("max_lag", 5L);
        Map<String, Object> conventions = new LinkedHashMap<>();
        conventions.put("chunks", List.of(40L));
        conventions.put("nan_policy", "omit");
        assertEquals("nan_policy must be one of 'raise', got 'omit'",
                rejects(ErrorKind.INVALID_PARAMETER, () -> Operations.run("accumulate", inputs, conventions))
                        .getMessage());
    }

    /**
     * The sums are held in units of a power of two per column (contract §4.1): data times 2^-1000
     * (about 1e-301, whose squares underflow) give the same sums to the bit, every exponent moved by
     * -1000, and blocks of very different magnitude merge into the sums of the one block.
     */
    @Test
    void sumsDoNotDependOnTheScale() {
        int c = 9;
        int m = 2;
        int p = 1;
        double[] e = new double[c * m];
        double[] t = new double[c * m];
        double[] y = new double[c * m * p];
        for (int i = 0; i < e.length; i++) {
            e[i] = Math.sin(1.7 * i) + 0.1 * i;
            t[i] = 3.0 + Math.cos(0.3 * i);
            y[i] = Math.cos(2.1 * i) * (i % 3);
        }
        StreamSums a = StreamSums.fromBlock(m, p, 3, true, e, t, y, c);
        StreamSums b = StreamSums.fromBlock(m, p, 3, true, Kernels.scaled(e, 1000), Kernels.scaled(t, 1000),
                Kernels.scaled(y, 1000), c);
        for (int j = 0; j < m; j++) {
            assertEquals(a.expE[j] - 1000, b.expE[j]);
            assertEquals(a.expT[j] - 1000, b.expT[j]);
            assertEquals(a.expY[j] - 1000, b.expY[j]);
        }
        assertTrue(Arrays.equals(a.prodE.hi, b.prodE.hi) && Arrays.equals(a.prodEY.hi, b.prodEY.hi)
                && Arrays.equals(a.products.hi, b.products.hi) && Arrays.equals(a.sqT.hi, b.sqT.hi));

        double[] mixed = e.clone();
        for (int i = 0; i < 3 * m; i++) {
            mixed[i] *= 1e-250; // the first three rows tiny, the rest large
        }
        for (int i = 3 * m; i < mixed.length; i++) {
            mixed[i] *= 1e100;
        }
        StreamSums whole = StreamSums.fromBlock(m, p, 3, true, mixed, mixed, mixed.clone(), c);
        StreamSums merged = StreamSums.fromBlock(m, p, 3, true, Arrays.copyOfRange(mixed, 0, 3 * m),
                Arrays.copyOfRange(mixed, 0, 3 * m), Arrays.copyOfRange(mixed, 0, 3 * m), 3);
        merged.mergeOwned(StreamSums.fromBlock(m, p, 3, true, Arrays.copyOfRange(mixed, 3 * m, c * m),
                Arrays.copyOfRange(mixed, 3 * m, c * m), Arrays.copyOfRange(mixed, 3 * m, c * m), c - 3));
        assertTrue(Arrays.equals(whole.expE, merged.expE));
        double[] got = merged.prodE.values();
        double size = Math.abs(whole.prodE.hi[0]) + Math.abs(whole.prodE.hi[1]);
        for (int i = 0; i < got.length; i++) {
            assertEquals(whole.prodE.hi[i], got[i], 1e-13 * size);
        }
    }
}
