package org.dynval;

/** A dense (N, m) matrix of samples by joints, row-major, as the data arrive. */
final class Matrix {
    private final double[] data;
    private final int n;
    private final int m;

    private Matrix(double[] data, int n, int m) {
        this.data = data;
        this.n = n;
        this.m = m;
    }

    static Matrix fromRowMajor(double[] data, int n, int m) {
        return new Matrix(data, n, m);
    }

    int n() {
        return n;
    }

    int m() {
        return m;
    }

    double get(int i, int j) {
        return data[i * m + j];
    }

    /** Joint j over all samples, as a new array. */
    double[] column(int j) {
        double[] out = new double[n];
        for (int i = 0; i < n; i++) {
            out[i] = data[i * m + j];
        }
        return out;
    }

    /** Every column, joint-major: {@code out[j][k]} is sample k of joint j. */
    double[][] columns() {
        double[][] out = new double[m][n];
        for (int i = 0; i < n; i++) {
            int base = i * m;
            for (int j = 0; j < m; j++) {
                out[j][i] = data[base + j];
            }
        }
        return out;
    }

    /** All N·m values in the lesson's flattening order (row-major). */
    double[] flat() {
        return data.clone();
    }

    /** The rows whose {@code keep} flag is set. */
    Matrix keepRows(boolean[] keep, int kept) {
        double[] out = new double[kept * m];
        int r = 0;
        for (int i = 0; i < n; i++) {
            if (keep[i]) {
                System.arraycopy(data, i * m, out, r * m, m);
                r++;
            }
        }
        return new Matrix(out, kept, m);
    }
}
