package org.dynval;

/**
 * Validation metrics of data that arrive in chunks (docs/contract.md §4.1): feed consecutive rows
 * with {@link #update}, end a record with {@link #breakSegment}, combine accumulators of
 * consecutive time ranges with {@link #merge}, and read {@link #result} at any time. The result
 * equals the in-memory functions on the concatenated rows with the same segments (within
 * rounding): per joint sse, rmse, max_abs_error, vaf, fit_percent, r2, residual mean and variance
 * (ddof 1), the adjusted autocorrelation, the adjusted cross-correlation with the regressor, and
 * the information criteria of the noise model.
 *
 * <p>The state does not grow with the number of rows: O(L·m·p + m²) sums, the first and last L
 * rows, and a buffer of a few times L rows that pools small chunks before they are summed
 * ({@link #retainedValues()} counts them all). L is {@code maxLag}.
 *
 * <pre>{@code
 * ValidationAccumulator acc = new ValidationAccumulator(4, 10, NoiseModel.POOLED);
 * for (int k = 0; k < n; k += 64) {
 *     acc.update(rows(meas, k, k + 64), rows(pred, k, k + 64));
 * }
 * ValidationAccumulator.Metrics metrics = acc.result();
 * double[][] rho = metrics.autocorrelation();   // [lag][joint]
 * }</pre>
 */
public final class ValidationAccumulator {
    /** Rows pooled before they are summed, at least: a block costs its junction products (L²) however short it is. */
    private static final int MIN_BLOCK_ROWS = 256;

    /**
     * Every metric of the rows so far; arrays are per joint {@code (m,)}, the autocorrelation
     * {@code [lag][joint]}, {@code rho} {@code [joint][column][lag]} (null without a regressor).
     */
    public record Metrics(
            long nSamples,
            double[] sse,
            double[] rmse,
            double[] maxAbsError,
            double[] vaf,
            double[] fitPercent,
            double[] r2,
            double[] residualMean,
            double[] residualVariance,
            double[][] autocorrelation,
            double[][][] rho,
            InformationCriteria criteria) {
    }

    private final long nParams;
    private final int maxLag;
    private final NoiseModel noiseModel;

    private int m = -1; // unknown until the first chunk with rows
    private int p = -1; // 0: no regressor
    private StreamSums sums; // null until rows have been summed
    private boolean breakFirst; // break_segment() before any summed row
    private double[] pendingE;
    private double[] pendingT;
    private double[] pendingY;
    private int pendingRows;
    private int blockRows;
    private int chunks;
    private long rowsSeen;

    /**
     * An empty accumulator. {@code nParams} >= 0 (the information criteria's p), {@code maxLag}
     * >= 0 (lags of the autocorrelation and cross-correlation; it must stay below the longest
     * record at {@link #result}), and the noise model of the criteria.
     */
    public ValidationAccumulator(long nParams, int maxLag, NoiseModel noiseModel) {
        this.nParams = Checks.checkNParams(nParams);
        if (maxLag < 0) {
            throw Checks.parameterError("max_lag", "an integer with max_lag >= 0", (long) maxLag);
        }
        if (noiseModel == null) {
            throw Checks.parameterError("noise_model", "one of 'pooled', 'per_joint', 'full'", null);
        }
        this.maxLag = maxLag;
        this.noiseModel = noiseModel;
    }

    /** An independent copy (a merge tree that reuses a partial result needs one). */
    public ValidationAccumulator copy() {
        ValidationAccumulator c = new ValidationAccumulator(nParams, maxLag, noiseModel);
        c.m = m;
        c.p = p;
        c.sums = sums == null ? null : sums.copy();
        c.breakFirst = breakFirst;
        c.pendingE = pendingE == null ? null : pendingE.clone();
        c.pendingT = pendingT == null ? null : pendingT.clone();
        c.pendingY = pendingY == null ? null : pendingY.clone();
        c.pendingRows = pendingRows;
        c.blockRows = blockRows;
        c.chunks = chunks;
        c.rowsSeen = rowsSeen;
        return c;
    }

    /** Rows accumulated so far. */
    public long nSamples() {
        return (sums == null ? 0 : sums.n) + pendingRows;
    }

    /**
     * Numbers the accumulator holds (sums, boundary rows and the block buffer, at its capacity):
     * set by m, p and maxLag on the first chunk, then constant however many rows follow.
     */
    public long retainedValues() {
        long buffer = pendingE == null ? 0 : pendingE.length + pendingT.length + pendingY.length;
        return buffer + (sums == null ? 0 : sums.retainedValues());
    }

    /** The next rows of one joint, {@code (c,)}. */
    public void update(double[] tauMeas, double[] tauPred) {
        updateChecked(tauMeas, tauPred, null);
    }

    /** The next rows, {@code (c, m)}; every chunk has the m of the first, and no regressor if the first had none. */
    public void update(double[][] tauMeas, double[][] tauPred) {
        updateChecked(tauMeas, tauPred, null);
    }

    /**
     * The next rows with the regressor's, {@code [c][m][p]}: every chunk has one, of the same p,
     * or none has (null).
     */
    public void update(double[][] tauMeas, double[][] tauPred, double[][][] regressor) {
        updateChecked(tauMeas, tauPred, regressor);
    }

    /**
     * Ends the current record: no lagged product joins the rows before and after (contract §1.1;
     * means stay overall). Breaks before any row, or repeated, make no empty record.
     */
    public void breakSegment() {
        flush();
        if (sums == null) {
            breakFirst = true;
        } else {
            sums.endBreak = true;
        }
    }

    /**
     * Adds {@code later}'s rows, which come after this accumulator's in time, and returns this.
     * Lags join across the junction unless this one ended, or {@code later} started, with a
     * break. {@code later} is not changed; merging is associative, so blocks may be combined in
     * any tree. Both need the same settings (InvalidParameter) and data of the same m and p
     * (ShapeMismatch).
     */
    public ValidationAccumulator merge(ValidationAccumulator later) {
        if (later == null) {
            throw Checks.parameterError("other", "a ValidationAccumulator", null);
        }
        checkSameSetting("n_params", later.nParams, nParams);
        checkSameSetting("max_lag", (long) later.maxLag, (long) maxLag);
        checkSameSetting("noise_model", later.noiseModel.contractName(), noiseModel.contractName());
        if (m >= 0 && later.m >= 0 && (m != later.m || p != later.p)) {
            throw new InputError(ErrorKind.SHAPE_MISMATCH, "other must hold data of the same shape, got m=" + later.m
                    + " joints and p=" + later.p + " regressor columns where this one has m=" + m + " and p=" + p);
        }
        later.flush(); // a change of representation only: its rows and breaks stay as they were
        StreamSums tail = later.sums == null ? null : later.sums.copy();
        boolean laterBreakFirst = later.breakFirst;
        int laterChunks = later.chunks;
        long laterRows = later.rowsSeen;
        flush();
        if (m < 0 && later.m >= 0) {
            setLayout(later.m, later.p);
        }
        if (tail == null) {
            if (laterBreakFirst) {
                breakSegment();
            }
        } else if (sums == null) {
            tail.startBreak |= breakFirst;
            sums = tail;
        } else {
            sums.mergeOwned(tail);
        }
        chunks += laterChunks;
        rowsSeen += laterRows;
        return this;
    }

    /**
     * The metrics of every row so far (the accumulator stays usable). TooFewSamples below 2 rows;
     * InvalidParameter when maxLag is not below the longest record.
     */
    public Metrics result() {
        flush();
        long n = sums == null ? 0 : sums.n;
        if (n < 2) {
            throw new InputError(ErrorKind.TOO_FEW_SAMPLES,
                    "ValidationAccumulator.result needs at least 2 samples, got N=" + n);
        }
        Checks.checkMaxLag((long) maxLag, (int) Math.min(sums.longest, Integer.MAX_VALUE));
        return StreamReport.metrics(sums, maxLag, nParams, noiseModel);
    }

    // ------------------------------------------------------------------ chunks

    private static void checkSameSetting(String name, Object theirs, Object mine) {
        if (!theirs.equals(mine)) {
            throw new InputError(ErrorKind.INVALID_PARAMETER, "other must be a ValidationAccumulator with the same "
                    + "settings, got " + name + "=" + Checks.repr(theirs) + " where this one has " + name + "="
                    + Checks.repr(mine));
        }
    }

    private InputError chunkError(InputError error) {
        return new InputError(error.kind(), "chunk " + chunks + ": " + error.getMessage());
    }

    private static boolean empty(Object x) {
        return x instanceof double[] ? ((double[]) x).length == 0
                : x instanceof double[][] ? ((double[][]) x).length == 0
                : x instanceof double[][][] && ((double[][][]) x).length == 0;
    }

    private void updateChecked(Object tauMeas, Object tauPred, double[][][] regressor) {
        if (empty(tauMeas) && empty(tauPred) && (regressor == null || empty(regressor))) {
            chunks++; // no rows: nothing to check against, nothing to add
            return;
        }
        Matrix meas;
        Matrix pred;
        Matrix reg = null;
        int cp = 0;
        try {
            NdArray a = Checks.toFloatArray(tauMeas, "tau_meas");
            NdArray b = Checks.toFloatArray(tauPred, "tau_pred");
            NdArray y = regressor == null ? null : Checks.toFloatArray(regressor, "regressor");
            meas = Checks.promoteSignal(a, "tau_meas");
            pred = Checks.promoteSignal(b, "tau_pred");
            Checks.checkSameShape("tau_meas", a, meas, "tau_pred", b, pred);
            int c = meas.n();
            if (m >= 0 && meas.m() != m) {
                throw new InputError(ErrorKind.SHAPE_MISMATCH, "tau_meas must have m=" + m
                        + " columns like the chunks before it, got shape " + Checks.formatShape(a.shape()));
            }
            if (m >= 0 && (y == null) != (p == 0)) {
                throw new InputError(ErrorKind.SHAPE_MISMATCH, "regressor must be given with every chunk or with none; "
                        + "the chunks before it had " + (p == 0 ? "none" : "one"));
            }
            if (y != null) {
                cp = Checks.regressorShape(y, "tau_meas", c, meas.m(), null);
                if (m >= 0 && cp != p) {
                    throw new InputError(ErrorKind.SHAPE_MISMATCH, "regressor must have p=" + p
                            + " columns like the chunks before it, got shape " + Checks.formatShape(y.shape()));
                }
                reg = Matrix.fromRowMajor(y.data(), c, meas.m() * cp);
            }
            checkFinite(meas, "tau_meas", 0);
            checkFinite(pred, "tau_pred", 0);
            if (reg != null) {
                checkFinite(reg, "regressor", cp);
            }
        } catch (InputError error) {
            throw chunkError(error);
        }
        if (m < 0) {
            setLayout(meas.m(), cp);
        }
        chunks++;
        rowsSeen += meas.n();
        feed(meas, pred, reg);
    }

    /** NonFiniteInput at the chunk's first bad value, with its row in the whole stream too. */
    private void checkFinite(Matrix a, String name, int nColumns) {
        try {
            Checks.checkFinite(a, name, nColumns);
        } catch (InputError error) {
            long row = rowsSeen;
            for (int i = 0; i < a.n(); i++) {
                boolean ok = true;
                for (int j = 0; j < a.m() && ok; j++) {
                    ok = Checks.inRange(a.get(i, j));
                }
                if (!ok) {
                    row += i;
                    break;
                }
            }
            throw new InputError(error.kind(), error.getMessage() + " (row " + row + " of the stream)");
        }
    }

    private void setLayout(int joints, int columns) {
        m = joints;
        p = columns;
        blockRows = Math.max(MIN_BLOCK_ROWS, 4 * (maxLag + 1));
        pendingE = new double[blockRows * m];
        pendingT = new double[blockRows * m];
        pendingY = new double[blockRows * m * p];
    }

    /** Rows of the current record: pooled in the buffer, summed a block at a time. */
    private void feed(Matrix meas, Matrix pred, Matrix reg) {
        int mp = m * p;
        for (int i = 0; i < meas.n(); i++) {
            int base = pendingRows * m;
            for (int j = 0; j < m; j++) {
                double t = meas.get(i, j);
                pendingT[base + j] = t;
                pendingE[base + j] = t - pred.get(i, j);
            }
            for (int q = 0; q < mp; q++) {
                pendingY[pendingRows * mp + q] = reg.get(i, q);
            }
            if (++pendingRows == blockRows) {
                flush();
            }
        }
    }

    private void flush() {
        if (pendingRows == 0) {
            return;
        }
        StreamSums block = StreamSums.fromBlock(m, p, maxLag, noiseModel == NoiseModel.FULL, pendingE, pendingT,
                pendingY, pendingRows);
        pendingRows = 0;
        if (sums == null) {
            block.startBreak = breakFirst;
            sums = block;
        } else {
            sums.mergeOwned(block);
        }
    }
}
