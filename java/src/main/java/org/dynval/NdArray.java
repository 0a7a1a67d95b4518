package org.dynval;

import java.util.Arrays;

/**
 * An n-dimensional array of real numbers in row-major order with the type it was given as
 * ({@code real}, {@code int} or {@code bool}): what the untyped entry point
 * {@link Operations#run} and the protocol hand to the library. Integer and boolean arrays are
 * converted to double once, as the contract says.
 */
public final class NdArray {
    /** Element type as the protocol names it. */
    public enum Type { REAL, INT, BOOL }

    private final int[] shape;
    private final double[] values;
    private final Type type;

    public NdArray(int[] shape, double[] values, Type type) {
        long count = 1;
        for (int d : shape) {
            if (d < 0) {
                throw new IllegalArgumentException("negative dimension in " + Arrays.toString(shape));
            }
            count *= d;
        }
        if (count != values.length) {
            throw new IllegalArgumentException("shape " + Arrays.toString(shape) + " does not hold "
                    + values.length + " values");
        }
        this.shape = shape.clone();
        this.values = values;
        this.type = type;
    }

    public NdArray(int[] shape, double[] values) {
        this(shape, values, Type.REAL);
    }

    /** A 1-D array {@code (N,)}. */
    public static NdArray of(double[] x) {
        return new NdArray(new int[] {x.length}, x.clone());
    }

    /**
     * A 2-D array {@code (N, m)} from rows. Ragged rows cannot form an array: they are the
     * contract's InvalidType ({@code got object}) when the value reaches a metric, so they are
     * rejected here with the same kind and message.
     */
    public static NdArray of(double[][] rows, String name) {
        int n = rows.length;
        int m = n == 0 ? 0 : rows[0].length;
        double[] flat = new double[n * m];
        for (int i = 0; i < n; i++) {
            if (rows[i] == null || rows[i].length != m) {
                throw new InputError(ErrorKind.INVALID_TYPE, name + " must be an array of real numbers, got object");
            }
            System.arraycopy(rows[i], 0, flat, i * m, m);
        }
        return new NdArray(new int[] {n, m}, flat);
    }

    /** A 3-D array {@code (N, m, p)}: sample, joint, regressor column. */
    public static NdArray of(double[][][] cube, String name) {
        int n = cube.length;
        int m = n == 0 ? 0 : cube[0].length;
        int p = (n == 0 || m == 0) ? 0 : cube[0][0].length;
        double[] flat = new double[n * m * p];
        int k = 0;
        for (double[][] sample : cube) {
            if (sample == null || sample.length != m) {
                throw new InputError(ErrorKind.INVALID_TYPE, name + " must be an array of real numbers, got object");
            }
            for (double[] row : sample) {
                if (row == null || row.length != p) {
                    throw new InputError(ErrorKind.INVALID_TYPE, name + " must be an array of real numbers, got object");
                }
                System.arraycopy(row, 0, flat, k, p);
                k += p;
            }
        }
        return new NdArray(new int[] {n, m, p}, flat);
    }

    public int[] shape() {
        return shape.clone();
    }

    public int ndim() {
        return shape.length;
    }

    public int dim(int i) {
        return shape[i];
    }

    public Type type() {
        return type;
    }

    /** The values in row-major order (not copied: callers must not modify them). */
    double[] data() {
        return values;
    }

    public double[] values() {
        return values.clone();
    }
}
