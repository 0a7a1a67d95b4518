package org.dynval;

import java.math.BigDecimal;
import java.math.BigInteger;
import java.util.ArrayList;
import java.util.List;
import java.util.Map;

/**
 * The input checks of the contract (docs/contract.md §2.1) and the texts of their messages.
 * Parameters arrive untyped ({@link Object}: {@code Long}, {@code BigInteger}, {@code Double},
 * {@code Boolean}, {@code String}, {@code List}, {@code null}) because the contract decides on the
 * kind of a value as well as on its range: {@code max_lag=true} and {@code ddof=1.0} are
 * InvalidParameter, not integers.
 */
final class Checks {
    private Checks() {
    }

    /** Largest accepted |x| in the data (contract §1.2). */
    static final double MAX_MAGNITUDE = 1e144;

    static final List<String> MULTIOUTPUT_OPTIONS = List.of("pooled", "raw_values", "uniform_average", "variance_weighted");
    static final List<String> CONVENTION_OPTIONS = List.of("per_element", "per_sample");
    static final List<String> NOISE_MODEL_OPTIONS = List.of("pooled", "per_joint", "full");
    static final List<String> NAN_POLICY_OPTIONS = List.of("raise", "omit");

    /** Minimum N per public function (contract §2.2). */
    static final Map<String, Integer> MIN_SAMPLES = Map.ofEntries(
            Map.entry("residuals", 1), Map.entry("sse", 1), Map.entry("rmse", 1),
            Map.entry("max_abs_error", 1), Map.entry("residual_mean", 1),
            Map.entry("vaf", 2), Map.entry("fit_percent", 2), Map.entry("r2", 2),
            Map.entry("residual_variance", 2), Map.entry("zero_mean_test", 2),
            Map.entry("autocorrelation", 2), Map.entry("ljung_box", 2), Map.entry("box_pierce", 2),
            Map.entry("cross_correlation", 2), Map.entry("aic", 2), Map.entry("bic", 2),
            Map.entry("criteria", 2));

    // ------------------------------------------------------------------ Python-style formatting

    /** A shape written as a Python tuple: {@code (5,)}, {@code (3, 2)}, {@code ()}. */
    static String formatShape(int[] shape) {
        if (shape.length == 1) {
            return "(" + shape[0] + ",)";
        }
        StringBuilder sb = new StringBuilder("(");
        for (int i = 0; i < shape.length; i++) {
            if (i > 0) {
                sb.append(", ");
            }
            sb.append(shape[i]);
        }
        return sb.append(')').toString();
    }

    /** A value as Python's {@code repr} writes it, so that messages read as in every backend. */
    static String repr(Object value) {
        if (value == null) {
            return "None";
        }
        if (value instanceof Boolean) {
            return ((Boolean) value) ? "True" : "False";
        }
        if (value instanceof Double) {
            return reprDouble((Double) value);
        }
        if (value instanceof String) {
            return "'" + ((String) value).replace("\\", "\\\\").replace("'", "\\'") + "'";
        }
        if (value instanceof List) {
            StringBuilder sb = new StringBuilder("[");
            boolean first = true;
            for (Object item : (List<?>) value) {
                if (!first) {
                    sb.append(", ");
                }
                sb.append(repr(item));
                first = false;
            }
            return sb.append(']').toString();
        }
        return String.valueOf(value);
    }

    /** Python's float repr: shortest digits, fixed notation for 1e-4 <= |x| < 1e16. */
    static String reprDouble(double x) {
        if (Double.isNaN(x)) {
            return "nan";
        }
        if (Double.isInfinite(x)) {
            return x > 0 ? "inf" : "-inf";
        }
        if (x == 0.0) {
            return (1.0 / x < 0) ? "-0.0" : "0.0";
        }
        BigDecimal d = new BigDecimal(Double.toString(x)).stripTrailingZeros();
        String digits = d.unscaledValue().abs().toString();
        int exponent = digits.length() - 1 - d.scale(); // decimal exponent of the first digit
        String sign = x < 0 ? "-" : "";
        if (exponent >= -4 && exponent < 16) {
            String plain = d.abs().toPlainString();
            return sign + (plain.contains(".") ? plain : plain + ".0");
        }
        String mantissa = digits.length() == 1 ? digits : digits.charAt(0) + "." + digits.substring(1);
        return sign + mantissa + "e" + (exponent < 0 ? "-" : "+") + String.format("%02d", Math.abs(exponent));
    }

    static String formatNonFinite(double v) {
        if (Double.isNaN(v)) {
            return "nan";
        }
        return v > 0 ? "inf" : "-inf";
    }

    static InputError parameterError(String param, String requirement, Object value) {
        return new InputError(ErrorKind.INVALID_PARAMETER, param + " must be " + requirement + ", got " + repr(value));
    }

    // ------------------------------------------------------------------ type and shape

    /** Convert an array argument, rejecting anything that is not real numbers (InvalidType). */
    static NdArray toFloatArray(Object x, String name) {
        if (x instanceof NdArray) {
            return (NdArray) x;
        }
        if (x instanceof double[]) {
            return NdArray.of((double[]) x);
        }
        if (x instanceof double[][]) {
            return NdArray.of((double[][]) x, name);
        }
        if (x instanceof double[][][]) {
            return NdArray.of((double[][][]) x, name);
        }
        if (x == null) {
            throw typeError(name, "NoneType");
        }
        if (x instanceof String) {
            throw typeError(name, "str");
        }
        if (x instanceof Boolean) {
            return new NdArray(new int[0], new double[] {((Boolean) x) ? 1.0 : 0.0}, NdArray.Type.BOOL);
        }
        if (x instanceof Long || x instanceof Integer) {
            return new NdArray(new int[0], new double[] {((Number) x).doubleValue()}, NdArray.Type.INT);
        }
        if (x instanceof Double) {
            return new NdArray(new int[0], new double[] {(Double) x});
        }
        if (x instanceof List) {
            List<?> items = (List<?>) x;
            double[] values = new double[items.size()];
            int longest = 0;
            boolean text = false;
            for (int i = 0; i < values.length; i++) {
                Object item = items.get(i);
                if (item instanceof Boolean) {
                    values[i] = ((Boolean) item) ? 1.0 : 0.0;
                } else if (item instanceof Long || item instanceof Double || item instanceof Integer) {
                    values[i] = ((Number) item).doubleValue();
                } else if (item instanceof String) {
                    text = true;
                    longest = Math.max(longest, ((String) item).length());
                } else {
                    throw typeError(name, "object");
                }
            }
            if (text) {
                throw typeError(name, "<U" + longest);
            }
            return new NdArray(new int[] {values.length}, values);
        }
        throw typeError(name, "object");
    }

    private static InputError typeError(String name, String what) {
        return new InputError(ErrorKind.INVALID_TYPE, name + " must be an array of real numbers, got " + what);
    }

    /** Check a signal's dimensions; {@code (N,)} becomes {@code (N, 1)}. */
    static Matrix promoteSignal(NdArray a, String name) {
        int[] shape = a.shape();
        if (a.ndim() == 1) {
            return Matrix.fromRowMajor(a.data(), shape[0], 1);
        }
        if (a.ndim() != 2) {
            throw new InputError(ErrorKind.INVALID_SHAPE,
                    name + " must be 1-D (N,) or 2-D (N, m), got shape " + formatShape(shape));
        }
        if (shape[1] == 0) {
            throw new InputError(ErrorKind.INVALID_SHAPE,
                    name + " must have at least one column, got shape " + formatShape(shape));
        }
        return Matrix.fromRowMajor(a.data(), shape[0], shape[1]);
    }

    static void checkSameShape(String nameA, NdArray a, Matrix a2, String nameB, NdArray b, Matrix b2) {
        if (a2.n() != b2.n() || a2.m() != b2.m()) {
            throw new InputError(ErrorKind.SHAPE_MISMATCH, nameA + " and " + nameB + " must have the same shape, got "
                    + formatShape(a.shape()) + " and " + formatShape(b.shape()));
        }
    }

    /** Check the regressor's shape against {@code e} (N, m); returns p, the number of columns. */
    static int regressorShape(NdArray y, String nameE, int n, int m, Object nJoints) {
        int[] s = y.shape();
        String shape = formatShape(s);
        if (s.length == 3) {
            if (s[2] == 0) {
                throw new InputError(ErrorKind.INVALID_SHAPE, "regressor must have at least one column, got shape " + shape);
            }
            if (s[0] != n || s[1] != m) {
                throw new InputError(ErrorKind.SHAPE_MISMATCH, "regressor must have shape (N, m, p) = (" + n + ", " + m
                        + ", p) to match " + nameE + ", got " + shape);
            }
            return s[2];
        }
        if (s.length == 2 && nJoints != null) {
            if (s[1] == 0) {
                throw new InputError(ErrorKind.INVALID_SHAPE, "regressor must have at least one column, got shape " + shape);
            }
            if ((long) s[0] != (long) n * m) {
                throw new InputError(ErrorKind.SHAPE_MISMATCH,
                        "regressor has " + s[0] + " rows, which is not N*m = " + n + "*" + m);
            }
            return s[1];
        }
        throw new InputError(ErrorKind.INVALID_SHAPE,
                "regressor must be 3-D (N, m, p) or 2-D (N*m, p) with n_joints, got shape " + shape);
    }

    static void checkMinSamples(String function, int n) {
        int k = MIN_SAMPLES.get(function);
        if (n < k) {
            throw new InputError(ErrorKind.TOO_FEW_SAMPLES, function + " needs at least " + k + " samples, got N=" + n);
        }
    }

    // ------------------------------------------------------------------ finiteness

    static boolean inRange(double v) {
        return Math.abs(v) <= MAX_MAGNITUDE; // false for NaN and ±inf too
    }

    /**
     * Raise NonFiniteInput at the first value (row-major) that is NaN, ±inf or beyond 1e144.
     * With {@code nColumns > 0} the array is a regressor viewed (N, m·p) and the location is
     * written as sample, joint and column.
     */
    static void checkFinite(Matrix a, String name, int nColumns) {
        for (int i = 0; i < a.n(); i++) {
            for (int j = 0; j < a.m(); j++) {
                double v = a.get(i, j);
                if (!inRange(v)) {
                    String where = nColumns > 0
                            ? "at sample " + i + ", joint " + (j / nColumns) + ", column " + (j % nColumns)
                            : "at row " + i + ", column " + j;
                    if (Double.isNaN(v) || Double.isInfinite(v)) {
                        throw new InputError(ErrorKind.NON_FINITE_INPUT,
                                name + " has a non-finite value (" + formatNonFinite(v) + ") " + where);
                    }
                    throw new InputError(ErrorKind.NON_FINITE_INPUT, name + " has a value out of range (" + reprDouble(v)
                            + ") " + where + ": |x| must be at most 1e+144");
                }
            }
        }
    }

    // ------------------------------------------------------------------ parameters

    /** A Java {@code long} integer (the contract's int64 bound); booleans and floats are not integers. */
    static boolean isInteger(Object v) {
        return v instanceof Long || v instanceof Integer;
    }

    static boolean isRealNumber(Object v) {
        return v instanceof Long || v instanceof Integer || v instanceof Double || v instanceof BigInteger;
    }

    static long asLong(Object v) {
        return ((Number) v).longValue();
    }

    private static String quoted(List<String> options) {
        StringBuilder sb = new StringBuilder();
        for (int i = 0; i < options.size(); i++) {
            if (i > 0) {
                sb.append(", ");
            }
            sb.append('\'').append(options.get(i)).append('\'');
        }
        return sb.toString();
    }

    static String checkChoice(String param, Object value, List<String> options) {
        if (!(value instanceof String) || !options.contains(value)) {
            throw parameterError(param, "one of " + quoted(options), value);
        }
        return (String) value;
    }

    static String checkMultioutput(Object value, List<String> allowed, String function) {
        checkChoice("multioutput", value, MULTIOUTPUT_OPTIONS);
        if (!allowed.contains(value)) {
            throw parameterError("multioutput", "one of " + quoted(allowed) + " for " + function, value);
        }
        return (String) value;
    }

    /** rmse's convention; {@code null} or "" mean the default (per_element for pooled), returned as "". */
    static String checkConvention(Object value, String multioutput) {
        if (value == null || "".equals(value)) {
            return "";
        }
        if (!"pooled".equals(multioutput)) {
            throw parameterError("convention", "None unless multioutput='pooled'", value);
        }
        return checkChoice("convention", value, CONVENTION_OPTIONS);
    }

    static int checkDdof(Object value, int n) {
        if (!isInteger(value) || asLong(value) < 0 || asLong(value) >= n) {
            throw parameterError("ddof", "an integer with 0 <= ddof < N=" + n, value);
        }
        return (int) asLong(value);
    }

    static int checkMaxLag(Object value, int limit) {
        if (!isInteger(value) || asLong(value) < 0 || asLong(value) >= limit) {
            throw parameterError("max_lag", "an integer with 0 <= max_lag < " + limit, value);
        }
        return (int) asLong(value);
    }

    static int[] checkLags(Object value, int limit) {
        String requirement = "a positive integer or a non-empty sequence of positive integers less than " + limit;
        List<Object> items = new ArrayList<>();
        if (isInteger(value)) {
            items.add(value);
        } else if (value instanceof List) {
            items.addAll((List<?>) value);
        } else if (value instanceof int[]) {
            for (int v : (int[]) value) {
                items.add((long) v);
            }
        } else {
            throw parameterError("lags", requirement, value);
        }
        if (items.isEmpty()) {
            throw parameterError("lags", requirement, value);
        }
        int[] lags = new int[items.size()];
        for (int i = 0; i < lags.length; i++) {
            Object v = items.get(i);
            if (!isInteger(v) || asLong(v) <= 0 || asLong(v) >= limit) {
                throw parameterError("lags", requirement, value);
            }
            lags[i] = (int) asLong(v);
        }
        return lags;
    }

    static int checkModelDf(Object value, int minLag) {
        if (!isInteger(value) || asLong(value) < 0 || asLong(value) >= minLag) {
            throw parameterError("model_df", "an integer with 0 <= model_df < " + minLag, value);
        }
        return (int) asLong(value);
    }

    static double checkLevel(Object value) {
        if (!isRealNumber(value)) {
            throw parameterError("level", "a number with 0 < level < 1", value);
        }
        double v = ((Number) value).doubleValue();
        if (!(v > 0 && v < 1)) {
            throw parameterError("level", "a number with 0 < level < 1", value);
        }
        return v;
    }

    static boolean checkAdjusted(Object value) {
        if (!(value instanceof Boolean)) {
            throw parameterError("adjusted", "True or False", value);
        }
        return (Boolean) value;
    }

    static long checkNParams(Object value) {
        if (!isInteger(value) || asLong(value) < 0) {
            throw parameterError("n_params", "an integer with n_params >= 0", value);
        }
        return asLong(value);
    }

    static long checkNParams(Object value, long nObs) {
        long p = checkNParams(value);
        if (!(p < nObs - 1)) {
            throw parameterError("n_params", "less than n_obs - 1 = " + (nObs - 1), value);
        }
        return p;
    }

    static long checkNObs(Object value) {
        if (!isInteger(value) || asLong(value) < 1) {
            throw parameterError("n_obs", "an integer with n_obs >= 1", value);
        }
        return asLong(value);
    }

    static double checkRss(Object value) {
        boolean ok = isRealNumber(value) && !(value instanceof BigInteger);
        double v = ok ? ((Number) value).doubleValue() : Double.NaN;
        if (!ok || !Double.isFinite(v) || v < 0) {
            throw parameterError("rss", "a finite number >= 0", value);
        }
        return v;
    }

    static long checkN(Object value) {
        if (!isInteger(value) || asLong(value) < 1) {
            throw parameterError("n", "an integer with n >= 1", value);
        }
        return asLong(value);
    }

    /** {@code n_joints}: None or m for a 3-D regressor; a positive divisor of the rows equal to m otherwise. */
    static void checkNJoints(Object value, int rows, int m, boolean threeD) {
        if (threeD && value == null) {
            return;
        }
        if (!isInteger(value) || asLong(value) <= 0 || (!threeD && rows % asLong(value) != 0)) {
            throw parameterError("n_joints", "a positive integer dividing the regressor rows", value);
        }
        if (asLong(value) != m) {
            throw parameterError("n_joints", "equal to the number of joints of e (m=" + m + ")", value);
        }
    }
}
