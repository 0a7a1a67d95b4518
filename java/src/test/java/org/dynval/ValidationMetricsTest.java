package org.dynval;

import static org.junit.jupiter.api.Assertions.assertArrayEquals;
import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertThrows;

import org.junit.jupiter.api.Test;

/** The lesson-shaped entry point, and the lesson's Java pitfalls that the port does not repeat. */
class ValidationMetricsTest {

    @Test
    void lessonExampleThroughTheLessonShapedEntryPoint() {
        double[] meas = {1.0, 2.5, 3.2, 4.1, 4.8, 6.1};
        double[] pred = {1.1, 2.4, 3.0, 4.3, 4.7, 6.0};
        double[][] m = new double[6][1];
        double[][] p = new double[6][1];
        for (int i = 0; i < 6; i++) {
            m[i][0] = meas[i];
            p[i][0] = pred[i];
        }
        ValidationMetrics.Metrics metrics = ValidationMetrics.compute(m, p, 2);
        // values of the lesson's own code for this single-joint example (docs build notes)
        assertEquals(0.14142135623730953, metrics.rmsePerElement(), 1e-15);
        assertEquals(metrics.rmsePerElement(), metrics.rmsePerSample(), 0.0);
        assertEquals(99.29467897521003, metrics.vafPooled(), 1e-12);
        assertEquals(-19.472138032568875, metrics.aic(), 1e-12);
        assertEquals(-19.888619094112766, metrics.bic(), 1e-12);
        assertArrayEquals(new double[] {metrics.r2Pooled()}, metrics.r2(), 1e-15);
    }

    @Test
    void multiJointFieldsAreConsistent() {
        double[][] meas = {{1.0, 10.0}, {2.0, 12.0}, {4.0, 9.0}, {3.0, 11.5}};
        double[][] pred = {{1.2, 10.5}, {1.9, 11.0}, {3.6, 9.4}, {3.1, 11.0}};
        ValidationMetrics.Metrics metrics = ValidationMetrics.compute(meas, pred, 1);
        assertEquals(metrics.sse()[0] + metrics.sse()[1], metrics.sseTotal(), 1e-14);
        assertEquals(Math.sqrt(metrics.sseTotal() / 8), metrics.rmsePerElement(), 1e-15);
        assertEquals(Math.sqrt(metrics.sseTotal() / 4), metrics.rmsePerSample(), 1e-15);
        assertEquals((metrics.r2()[0] + metrics.r2()[1]) / 2, metrics.r2UniformAverage(), 1e-15);
        assertEquals(2, metrics.nJoints());
    }

    /**
     * The lesson decides a constant target on its rounded TSS: ten values 0.1 have the float mean
     * 0.09999999999999999, so its TSS is 1.9e-33 and its R² about −5.2e29 (measured with the
     * lesson's class). The contract decides on min == max: −inf.
     */
    @Test
    void constantTargetWhoseMeanRoundsIsStillConstant() {
        double[][] meas = new double[10][1];
        double[][] pred = new double[10][1];
        for (int i = 0; i < 10; i++) {
            meas[i][0] = 0.1;
            pred[i][0] = 0.1 + (i % 2 == 0 ? 0.01 : -0.01);
        }
        ValidationMetrics.Metrics metrics = ValidationMetrics.compute(meas, pred, 1);
        assertEquals(Double.NEGATIVE_INFINITY, metrics.r2Pooled());
        assertEquals(Double.NEGATIVE_INFINITY, metrics.vafPooled());
        assertEquals(Double.NEGATIVE_INFINITY, metrics.fitPercentPooled());
    }

    /** The lesson returns NaN/−inf for N = 1 and NaN for NaN data; the port rejects both. */
    @Test
    void inputsTheLessonAcceptsSilently() {
        InputError one = assertThrows(InputError.class,
                () -> ValidationMetrics.compute(new double[][] {{1.0}}, new double[][] {{0.5}}, 0));
        assertEquals(ErrorKind.TOO_FEW_SAMPLES, one.kind());
        InputError nan = assertThrows(InputError.class,
                () -> ValidationMetrics.compute(new double[][] {{1.0}, {Double.NaN}, {3.0}},
                        new double[][] {{1.0}, {2.0}, {3.0}}, 0));
        assertEquals(ErrorKind.NON_FINITE_INPUT, nan.kind());
        InputError big = assertThrows(InputError.class,
                () -> ValidationMetrics.compute(new double[][] {{1e200}, {-1e200}, {0.0}},
                        new double[][] {{0.0}, {0.0}, {0.0}}, 0));
        assertEquals(ErrorKind.NON_FINITE_INPUT, big.kind());
    }
}
