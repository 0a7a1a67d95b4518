package org.dynval;

import static org.junit.jupiter.api.Assertions.assertArrayEquals;
import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertThrows;

import java.math.BigInteger;
import java.util.HashMap;
import java.util.List;
import java.util.Map;
import org.junit.jupiter.api.Test;

/** The untyped entry point: kinds of parameter values, the check order, output names and shapes. */
class OperationsTest {

    private static NdArray array(int[] shape, double... values) {
        return new NdArray(shape, values);
    }

    private static final NdArray E = array(new int[] {5, 2}, 0.5, 0.0, -0.5, 0.5, 0.5, -0.5, 0.25, 0.0, -0.75, 1.0);

    private static Map<String, Object> map(Object... keyValues) {
        Map<String, Object> out = new HashMap<>();
        for (int i = 0; i < keyValues.length; i += 2) {
            out.put((String) keyValues[i], keyValues[i + 1]);
        }
        return out;
    }

    private static ErrorKind kindOf(String op, Map<String, Object> inputs, Map<String, Object> conventions) {
        InputError error = assertThrows(InputError.class, () -> Operations.run(op, inputs, conventions));
        return error.kind();
    }

    @Test
    void booleansAndIntegralFloatsAreNotIntegers() {
        assertEquals(ErrorKind.INVALID_PARAMETER, kindOf("autocorrelation", map("e", E, "max_lag", true), map()));
        assertEquals(ErrorKind.INVALID_PARAMETER, kindOf("autocorrelation", map("e", E, "max_lag", 2.0), map()));
        assertEquals(ErrorKind.INVALID_PARAMETER, kindOf("residual_variance", map("e", E), map("ddof", true)));
        assertEquals(ErrorKind.INVALID_PARAMETER, kindOf("autocorrelation", map("e", E, "max_lag", 1L),
                map("adjusted", "yes")));
        // beyond int64: the parameter's requirement fails
        assertEquals(ErrorKind.INVALID_PARAMETER, kindOf("aic", map("tau_meas", E, "tau_pred", E,
                "n_params", new BigInteger("9223372036854775808")), map()));
        Map<String, Operations.Output> ok = Operations.run("autocorrelation", map("e", E, "max_lag", 2L), map());
        assertArrayEquals(new int[] {3, 2}, ok.get("value").shape());
    }

    @Test
    void checkOrderTypeShapeSizeFinitenessParameters() {
        NdArray nanE = array(new int[] {4, 1}, 1.0, Double.NaN, 0.0, 1.0);
        // a bad parameter loses against non-finite data ...
        assertEquals(ErrorKind.NON_FINITE_INPUT, kindOf("autocorrelation", map("e", nanE, "max_lag", 9L), map()));
        assertEquals(ErrorKind.NON_FINITE_INPUT, kindOf("r2", map("tau_meas", nanE, "tau_pred", nanE),
                map("multioutput", "bogus")));
        // ... and against too few samples, which loses against a shape mismatch
        NdArray one = array(new int[] {1, 2}, 1.0, 2.0);
        assertEquals(ErrorKind.TOO_FEW_SAMPLES, kindOf("r2", map("tau_meas", one, "tau_pred", one),
                map("multioutput", "bogus")));
        assertEquals(ErrorKind.SHAPE_MISMATCH, kindOf("r2", map("tau_meas", nanE, "tau_pred", one), map()));
        // type before shape, argument order within a step
        assertEquals(ErrorKind.INVALID_TYPE, kindOf("r2", map("tau_meas", array(new int[] {2, 2, 2}, new double[8]),
                "tau_pred", null), map()));
        assertEquals(ErrorKind.INVALID_TYPE, kindOf("r2", map("tau_meas", "abc", "tau_pred", E), map()));
        assertEquals(ErrorKind.INVALID_SHAPE, kindOf("r2", map("tau_meas", 1.0, "tau_pred", 1.0), map()));
        // with omit nothing is non-finite any more, and the sizes are checked again
        NdArray mostlyNan = array(new int[] {3, 1}, 1.0, Double.NaN, 3.0);
        NdArray inf = array(new int[] {3, 1}, 1.0, 2.0, Double.POSITIVE_INFINITY);
        assertEquals(ErrorKind.TOO_FEW_SAMPLES, kindOf("r2", map("tau_meas", mostlyNan, "tau_pred", inf),
                map("nan_policy", "omit")));
        assertEquals(ErrorKind.INVALID_PARAMETER, kindOf("r2", map("tau_meas", E, "tau_pred", E),
                map("nan_policy", "ignore")));
    }

    @Test
    void multioutputAcceptedPerOperation() {
        Map<String, Object> data = map("tau_meas", E, "tau_pred", E);
        assertEquals(ErrorKind.INVALID_PARAMETER, kindOf("sse", data, map("multioutput", "uniform_average")));
        assertEquals(ErrorKind.INVALID_PARAMETER, kindOf("max_abs_error", data, map("multioutput", "variance_weighted")));
        assertEquals(ErrorKind.INVALID_PARAMETER, kindOf("rmse", data, map("multioutput", "variance_weighted")));
        assertEquals(ErrorKind.INVALID_PARAMETER, kindOf("rmse", data,
                map("multioutput", "raw_values", "convention", "per_sample")));
        Operations.run("rmse", data, map("multioutput", "uniform_average", "convention", null));
        Operations.run("vaf", data, map("multioutput", "variance_weighted"));
    }

    @Test
    void stackedRegressorNeedsNJoints() {
        NdArray stacked = array(new int[] {10, 1}, 1, 2, 3, 4, 5, 6, 7, 8, 9, 11);
        assertEquals(ErrorKind.INVALID_SHAPE, kindOf("cross_correlation", map("e", E, "regressor", stacked,
                "max_lag", 1L), map()));
        Map<String, Operations.Output> out = Operations.run("cross_correlation", map("e", E, "regressor", stacked,
                "max_lag", 1L, "n_joints", 2L), map());
        assertArrayEquals(new int[] {2, 1, 2}, out.get("rho").shape());
        assertArrayEquals(new int[] {2, 1}, out.get("constant_mask").shape());
        assertEquals(ErrorKind.INVALID_PARAMETER, kindOf("cross_correlation", map("e", E, "regressor", stacked,
                "max_lag", 1L, "n_joints", 5L), map()));
    }

    @Test
    void outputNamesAndShapes() {
        Map<String, Operations.Output> zm = Operations.run("zero_mean_test", map("e", E), map("segments", null));
        assertEquals(List.of("mean", "std", "n_samples", "statistic_iid", "pvalue_iid", "df_iid", "statistic_eff",
                "pvalue_eff", "df_eff", "n_eff", "bandwidth"), List.copyOf(zm.keySet()));
        assertEquals(0, zm.get("n_samples").shape().length);
        Map<String, Operations.Output> lb = Operations.run("ljung_box", map("e", E, "lags", List.of(1L, 3L)), map());
        assertArrayEquals(new int[] {2, 2}, lb.get("statistic").shape());
        assertArrayEquals(new double[] {1, 3}, lb.get("df").values());
        NdArray oneD = array(new int[] {5}, 1, 2, 0, 4, 3);
        assertArrayEquals(new int[] {3}, Operations.run("autocorrelation", map("e", oneD, "max_lag", 2L), map())
                .get("value").shape());
        Map<String, Operations.Output> ic = Operations.run("criteria", map("tau_meas", E, "tau_pred", oneD2()), map(
                "n_params", 1L));
        assertEquals(10.0, ic.get("n_obs").values()[0]);
    }

    private static NdArray oneD2() {
        return array(new int[] {5, 2}, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0);
    }

    @Test
    void unknownOperationIsNotAContractError() {
        assertThrows(Operations.UnknownCall.class, () -> Operations.run("median", map(), map()));
    }
}
