package org.dynval;

import java.math.BigDecimal;
import java.math.MathContext;
import java.math.RoundingMode;
import java.util.Locale;
import java.util.regex.Pattern;

/**
 * Numbers of the conformance protocol (golden/PROTOCOL.md §3, §8): 17 significant digits in
 * decimal exponent form, {@code nan}, {@code inf}, {@code -inf}. Locale-independent: the digits
 * come from the exact binary value through {@link BigDecimal}, never from a formatter that a
 * default locale could give a decimal comma.
 */
public final class ProtocolNumbers {
    private ProtocolNumbers() {
    }

    private static final MathContext SEVENTEEN = new MathContext(17, RoundingMode.HALF_EVEN);
    private static final Pattern DECIMAL = Pattern.compile("[+-]?([0-9]+(\\.[0-9]*)?|\\.[0-9]+)([eE][+-]?[0-9]+)?");

    /** Write one number: {@code d.dddddddddddddddde±XX}, or nan / inf / -inf. */
    public static String writeReal(double x) {
        if (Double.isNaN(x)) {
            return "nan";
        }
        if (Double.isInfinite(x)) {
            return x > 0 ? "inf" : "-inf";
        }
        if (x == 0.0) {
            return (1.0 / x < 0 ? "-" : "") + "0.0000000000000000e+00";
        }
        BigDecimal rounded = new BigDecimal(x).round(SEVENTEEN);
        String digits = rounded.unscaledValue().abs().toString();
        int exponent = digits.length() - 1 - rounded.scale();
        StringBuilder sb = new StringBuilder(24);
        if (x < 0) {
            sb.append('-');
        }
        sb.append(digits.charAt(0)).append('.');
        sb.append(digits, 1, Math.min(digits.length(), 17));
        for (int i = digits.length(); i < 17; i++) {
            sb.append('0');
        }
        sb.append(exponent < 0 ? "e-" : "e+");
        int abs = Math.abs(exponent);
        if (abs < 10) {
            sb.append('0');
        }
        sb.append(abs);
        return sb.toString();
    }

    /** Read one number token; throws NumberFormatException when it is not a protocol number. */
    public static double readReal(String token) {
        String t = token.toLowerCase(Locale.ROOT);
        boolean negative = t.startsWith("-");
        String u = (t.startsWith("-") || t.startsWith("+")) ? t.substring(1) : t;
        if (u.equals("nan") || (u.startsWith("nan(") && u.endsWith(")"))) {
            return Double.NaN;
        }
        if (u.equals("inf") || u.equals("infinity")) {
            return negative ? Double.NEGATIVE_INFINITY : Double.POSITIVE_INFINITY;
        }
        if (!DECIMAL.matcher(t).matches()) {
            throw new NumberFormatException("not a protocol number: " + token);
        }
        return Double.parseDouble(t);
    }
}
