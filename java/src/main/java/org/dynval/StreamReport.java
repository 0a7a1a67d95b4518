package org.dynval;

import java.util.Arrays;

/**
 * The metrics of {@link ValidationAccumulator#result} from the accumulated sums: every sum is
 * first moved to the overall mean (contract §1.1: means are overall, lags stay inside records)
 * with the identity of {@link StreamSums}, then the in-memory definitions apply, with the same
 * degenerate values ({@link Dynval#fitValue}, {@link Dynval#assemble}). The sums are in the
 * power-of-two units of their columns ({@link StreamSums}): ratios are formed in them, where the
 * exponents cancel, and sums of squares, means and variances are put back with their exponents.
 */
final class StreamReport {
    private StreamReport() {
    }

    static ValidationAccumulator.Metrics metrics(StreamSums st, int maxLag, long nParams, NoiseModel noiseModel) {
        int m = st.m;
        int p = st.p;
        int mp = m * p;
        long n = st.n;
        double nn = n;
        double[] cur = st.curE.values();
        double[] lag = st.lagE.values();
        double[] prod = st.prodE.values();
        // a = ē − K_e: small, because the centres follow the running means
        double[] a = new double[m];
        double[] meanE = new double[m];
        boolean[] eConstant = new boolean[m];
        for (int j = 0; j < m; j++) {
            a[j] = cur[j] / nn;
            meanE[j] = st.kE[j] + a[j];
            eConstant[j] = st.minE[j] == st.maxE[j];
        }
        double[][] cov = new double[maxLag + 1][m]; // Σ(e_t − ē)(e_{t−ℓ} − ē) over the pairs
        for (int l = 0; l <= maxLag; l++) {
            for (int j = 0; j < m; j++) {
                int i = l * m + j;
                cov[l][j] = prod[i] - a[j] * (cur[i] + lag[i]) + st.pairs[l] * a[j] * a[j];
            }
        }
        double[] ssc = new double[m];
        for (int j = 0; j < m; j++) {
            ssc[j] = eConstant[j] ? 0.0 : Math.max(cov[0][j], 0.0);
        }
        double[] sumT = st.sumT.values();
        double[] sqT = st.sqT.values();

        double[] sse = new double[m];
        double[] sseScaled = new double[m]; // Σe² in units 4^expE
        double[] rmse = new double[m];
        double[] maxAbs = new double[m];
        double[] vaf = new double[m];
        double[] fit = new double[m];
        double[] r2 = new double[m];
        double[] variance = new double[m];
        for (int j = 0; j < m; j++) {
            boolean tConstant = st.minT[j] == st.maxT[j];
            double tss = tConstant ? 0.0 : Math.max(sqT[j] - sumT[j] * sumT[j] / nn, 0.0);
            // both terms >= 0: nothing cancels
            int k = st.expE[j];
            sseScaled[j] = ssc[j] + nn * meanE[j] * meanE[j];
            Kernels.ScaledSum sseJ = new Kernels.ScaledSum(sseScaled[j], k);
            sse[j] = sseJ.value();
            rmse[j] = sseJ.rootMean(nn);
            maxAbs[j] = Math.max(Math.abs(st.minE[j]), Math.abs(st.maxE[j]));
            Dynval.FitParts parts = new Dynval.FitParts(sseJ, new Kernels.ScaledSum(ssc[j], k), eConstant[j],
                    new Kernels.ScaledSum(tss, st.expT[j]), tConstant);
            vaf[j] = Dynval.fitValue(Dynval.FitMetric.VAF, parts);
            fit[j] = Dynval.fitValue(Dynval.FitMetric.FIT_PERCENT, parts);
            r2[j] = Dynval.fitValue(Dynval.FitMetric.R2, parts);
            variance[j] = Math.scalb(ssc[j] / (nn - 1.0), 2 * k);
        }

        double[][] acf = new double[maxLag + 1][m];
        for (int j = 0; j < m; j++) {
            boolean dead = eConstant[j] || ssc[j] == 0.0;
            for (int l = 0; l <= maxLag; l++) {
                acf[l][j] = dead ? Double.NaN : l == 0 ? 1.0 : (cov[l][j] / st.pairs[l]) / (ssc[j] / nn);
            }
        }

        double[][][] rho = null;
        if (p > 0) {
            double[] lagY = st.lagY.values();
            double[] prodEY = st.prodEY.values();
            double[] sqY = st.sqY.values();
            rho = new double[m][p][maxLag + 1];
            for (int j = 0; j < m; j++) {
                for (int c = 0; c < p; c++) {
                    int q = j * p + c;
                    double b = lagY[q] / nn;
                    boolean yConstant = st.minY[q] == st.maxY[q];
                    double ssY = yConstant ? 0.0 : Math.max(sqY[q] - lagY[q] * lagY[q] / nn, 0.0);
                    if (yConstant || eConstant[j] || ssc[j] == 0.0 || ssY == 0.0) {
                        Arrays.fill(rho[j][c], Double.NaN);
                        continue;
                    }
                    // two roots, not the root of the product (contract §1.3)
                    double scale = Math.sqrt(ssc[j] / nn) * Math.sqrt(ssY / nn);
                    for (int l = 0; l <= maxLag; l++) {
                        int i = l * mp + q;
                        double c0 = prodEY[i] - b * cur[l * m + j] - a[j] * lagY[i] + st.pairs[l] * a[j] * b;
                        rho[j][c][l] = (c0 / st.pairs[l]) / scale;
                    }
                }
            }
        }

        InformationCriteria ic = criteria(st, noiseModel, nParams, sseScaled, meanE, cur);
        double[] mean = new double[m];
        for (int j = 0; j < m; j++) {
            mean[j] = Math.scalb(meanE[j], st.expE[j]);
        }
        return new ValidationAccumulator.Metrics(n, sse, rmse, maxAbs, vaf, fit, r2, mean, variance, acf, rho, ic);
    }

    /**
     * The criteria of contract §3.7 under the noise model, from the per-joint SSE in units 4^expE
     * (and EᵀE for full, on the largest joint's exponent), logarithms taking the exponents exactly.
     */
    private static InformationCriteria criteria(StreamSums st, NoiseModel model, long nParams, double[] sse,
            double[] meanE, double[] cur) {
        int m = st.m;
        long n = st.n;
        String name = model.contractName();
        double ln2 = Math.log(2.0);
        if (model == NoiseModel.POOLED) {
            int top = Integer.MIN_VALUE; // the largest exponent among joints with a non-zero SSE
            for (int j = 0; j < m; j++) {
                if (sse[j] > 0.0) {
                    top = Math.max(top, st.expE[j]);
                }
            }
            top = top == Integer.MIN_VALUE ? 0 : top;
            double[] parts = new double[m];
            for (int j = 0; j < m; j++) {
                parts[j] = Math.scalb(sse[j], 2 * (st.expE[j] - top));
            }
            double total = Kernels.sum(parts);
            long nv = n * m;
            if (total == 0.0) {
                return Dynval.assemble(Double.NEGATIVE_INFINITY, nv, nv, 0.0, nParams, name);
            }
            Kernels.ScaledSum pooled = new Kernels.ScaledSum(total, top);
            return Dynval.assemble(nv * pooled.logMean(nv), nv, nv, Math.scalb(total / nv, 2 * top), nParams, name);
        }
        if (model == NoiseModel.PER_JOINT) {
            double[] logs = new double[m];
            for (int j = 0; j < m; j++) {
                if (sse[j] == 0.0) {
                    return Dynval.assemble(Double.NEGATIVE_INFINITY, n, n, 0.0, nParams, name);
                }
                logs[j] = new Kernels.ScaledSum(sse[j], st.expE[j]).logMean(n);
            }
            double logSize = Kernels.sum(logs);
            return Dynval.assemble(n * logSize, n, n, Math.exp(logSize), nParams, name);
        }
        // full: Σ̂ = EᵀE/N, not demeaned: the centred products plus the outer product of the means,
        // on one exponent for the whole matrix (the largest joint's)
        int top = Integer.MIN_VALUE;
        for (int j = 0; j < m; j++) {
            top = Math.max(top, st.expE[j]);
        }
        double[] g = st.products.values();
        double[][] sigma = new double[m][m];
        for (int i = 0; i < m; i++) {
            for (int k = 0; k < m; k++) {
                double centred = Math.scalb(g[i * m + k] - cur[i] * cur[k] / n, st.expE[i] + st.expE[k] - 2 * top);
                sigma[i][k] = centred / n + Math.scalb(meanE[i], st.expE[i] - top) * Math.scalb(meanE[k], st.expE[k] - top);
            }
        }
        double[] eig = Kernels.symmetricEigenvalues(sigma);
        double largest = eig[m - 1];
        // numpy's matrix_rank tolerance decides singularity, as in the in-memory criteria
        if (largest <= 0.0 || eig[0] <= m * Math.ulp(1.0) * largest) {
            return Dynval.assemble(Double.NEGATIVE_INFINITY, n, n, 0.0, nParams, name);
        }
        double[] logs = new double[m];
        for (int i = 0; i < m; i++) {
            logs[i] = Math.log(eig[i]);
        }
        double logDet = Kernels.sum(logs) + 2.0 * top * m * ln2;
        return Dynval.assemble(n * logDet, n, n, Math.exp(logDet), nParams, name);
    }
}
