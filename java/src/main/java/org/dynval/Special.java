package org.dynval;

/**
 * The special functions the port needs, written for this library (java.base has none of them):
 * the log-gamma function, the regularized incomplete gamma and beta functions, the chi-squared
 * and Student t survival functions, and the standard normal quantile.
 *
 * <p>Accuracy goal: a few units of 1e-15 relative, well inside the corpus tolerances (p-values
 * 1e-12 relative plus the spread from their statistic's tolerance).
 */
public final class Special {
    private Special() {
    }

    private static final double LN_SQRT_2PI = 0.91893853320467274178032973640562;
    private static final double EPS = 1e-17;
    private static final double TINY = 1e-300;
    private static final int MAX_ITERATIONS = 100_000;

    /** Below this survival probability the logarithm is taken from the continued fraction in log space. */
    static final double LOG_SF_SWITCH = 1e-280;

    // ------------------------------------------------------------------ log-gamma

    /** Stirling series remainder lgamma(x) − [(x − ½)ln x − x + ln√(2π)] for x >= 15. */
    private static double stirlingCorrection(double x) {
        double r = 1.0 / x;
        double r2 = r * r;
        // Bernoulli terms B_2k / (2k(2k−1) x^(2k−1)); at x = 15 the first omitted term is below 1e-19.
        return r * (1.0 / 12 + r2 * (-1.0 / 360 + r2 * (1.0 / 1260 + r2 * (-1.0 / 1680 + r2 * (1.0 / 1188
                + r2 * (-691.0 / 360360 + r2 * (1.0 / 156 + r2 * (-3617.0 / 122400))))))));
    }

    /** ln Γ(x) for x > 0. */
    public static double lgamma(double x) {
        if (Double.isNaN(x) || x <= 0) {
            return Double.NaN;
        }
        if (Double.isInfinite(x)) {
            return Double.POSITIVE_INFINITY;
        }
        if (x >= 15.0) {
            return (x - 0.5) * Math.log(x) - x + LN_SQRT_2PI + stirlingCorrection(x);
        }
        // Γ(x) = Γ(x + k) / (x (x+1) ... (x+k−1)), shifted up to the Stirling range.
        double product = 1.0;
        double z = x;
        while (z < 15.0) {
            product *= z;
            z += 1.0;
        }
        return (z - 0.5) * Math.log(z) - z + LN_SQRT_2PI + stirlingCorrection(z) - Math.log(product);
    }

    /**
     * ln Γ(a + b) − ln Γ(a) without the cancellation of two large logarithms (a large, b small):
     * needed by the Student t distribution with many degrees of freedom.
     */
    static double lgammaDifference(double a, double b) {
        if (a < 15.0 || a + b < 15.0) {
            return lgamma(a + b) - lgamma(a);
        }
        // (a+b−½)ln(a+b) − (a−½)ln a − b = (a−½)·log1p(b/a) + b·ln(a+b) − b
        return (a - 0.5) * Math.log1p(b / a) + b * Math.log(a + b) - b
                + stirlingCorrection(a + b) - stirlingCorrection(a);
    }

    /** ln B(a, b). */
    static double lbeta(double a, double b) {
        double big = Math.max(a, b);
        double small = Math.min(a, b);
        return lgamma(small) - lgammaDifference(big, small);
    }

    // ------------------------------------------------------------------ incomplete gamma

    /** ln(x^a e^(−x) / Γ(a)): the common factor of both incomplete gamma expansions. */
    private static double logGammaPrefix(double a, double x) {
        return a * Math.log(x) - x - lgamma(a);
    }

    /** Series for P(a, x), used for x < a + 1. */
    private static double lowerSeries(double a, double x) {
        double term = 1.0 / a;
        double sum = term;
        for (int n = 1; n < MAX_ITERATIONS; n++) {
            term *= x / (a + n);
            sum += term;
            if (Math.abs(term) < Math.abs(sum) * EPS) {
                break;
            }
        }
        return Math.exp(logGammaPrefix(a, x)) * sum;
    }

    /**
     * ln of the continued fraction part h of Q(a, x) = x^a e^(−x) / Γ(a) · h (modified Lentz),
     * used for x >= a + 1.
     */
    private static double upperFractionLog(double a, double x) {
        double b = x + 1.0 - a;
        double c = 1.0 / TINY;
        double d = 1.0 / b;
        double h = d;
        for (int i = 1; i < MAX_ITERATIONS; i++) {
            double an = -i * (i - a);
            b += 2.0;
            d = an * d + b;
            if (Math.abs(d) < TINY) {
                d = TINY;
            }
            c = b + an / c;
            if (Math.abs(c) < TINY) {
                c = TINY;
            }
            d = 1.0 / d;
            double delta = d * c;
            h *= delta;
            if (Math.abs(delta - 1.0) < 1e-16) {
                break;
            }
        }
        return Math.log(h);
    }

    /** Regularized lower incomplete gamma P(a, x) = γ(a, x)/Γ(a), a > 0, x >= 0. */
    public static double gammaP(double a, double x) {
        if (Double.isNaN(a) || Double.isNaN(x) || a <= 0 || x < 0) {
            return Double.NaN;
        }
        if (x == 0) {
            return 0.0;
        }
        if (Double.isInfinite(x)) {
            return 1.0;
        }
        if (x < a + 1.0) {
            return lowerSeries(a, x);
        }
        return 1.0 - Math.exp(logGammaPrefix(a, x) + upperFractionLog(a, x));
    }

    /** Regularized upper incomplete gamma Q(a, x) = Γ(a, x)/Γ(a) = 1 − P(a, x). */
    public static double gammaQ(double a, double x) {
        if (Double.isNaN(a) || Double.isNaN(x) || a <= 0 || x < 0) {
            return Double.NaN;
        }
        if (x == 0) {
            return 1.0;
        }
        if (Double.isInfinite(x)) {
            return 0.0;
        }
        if (x < a + 1.0) {
            return 1.0 - lowerSeries(a, x);
        }
        return Math.exp(logGammaPrefix(a, x) + upperFractionLog(a, x));
    }

    /** ln Q(a, x), finite far below the smallest double (the continued fraction stays in log space). */
    public static double logGammaQ(double a, double x) {
        if (Double.isNaN(a) || Double.isNaN(x) || a <= 0 || x < 0) {
            return Double.NaN;
        }
        if (x == 0) {
            return 0.0;
        }
        if (Double.isInfinite(x)) {
            return Double.NEGATIVE_INFINITY;
        }
        if (x < a + 1.0) {
            return Math.log1p(-lowerSeries(a, x));
        }
        return logGammaPrefix(a, x) + upperFractionLog(a, x);
    }

    /** Chi-squared survival function P(X > q) with {@code df} degrees of freedom. */
    public static double chi2Sf(double q, double df) {
        if (Double.isNaN(q)) {
            return Double.NaN;
        }
        if (q <= 0) {
            return 1.0;
        }
        return gammaQ(df / 2.0, q / 2.0);
    }

    /** ln of {@link #chi2Sf}, accurate where the probability itself underflows to 0. */
    public static double chi2LogSf(double q, double df) {
        if (Double.isNaN(q)) {
            return Double.NaN;
        }
        if (q <= 0) {
            return 0.0;
        }
        double a = df / 2.0;
        double x = q / 2.0;
        double sf = gammaQ(a, x);
        if (sf < LOG_SF_SWITCH && x > a + 1.0) {
            return logGammaQ(a, x);
        }
        return Math.log(sf);
    }

    // ------------------------------------------------------------------ incomplete beta

    /** Continued fraction of the incomplete beta function (modified Lentz). */
    private static double betaFraction(double a, double b, double x) {
        double qab = a + b;
        double qap = a + 1.0;
        double qam = a - 1.0;
        double c = 1.0;
        double d = 1.0 - qab * x / qap;
        if (Math.abs(d) < TINY) {
            d = TINY;
        }
        d = 1.0 / d;
        double h = d;
        for (int m = 1; m < MAX_ITERATIONS; m++) {
            int m2 = 2 * m;
            double aa = m * (b - m) * x / ((qam + m2) * (a + m2));
            d = 1.0 + aa * d;
            if (Math.abs(d) < TINY) {
                d = TINY;
            }
            c = 1.0 + aa / c;
            if (Math.abs(c) < TINY) {
                c = TINY;
            }
            d = 1.0 / d;
            h *= d * c;
            aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
            d = 1.0 + aa * d;
            if (Math.abs(d) < TINY) {
                d = TINY;
            }
            c = 1.0 + aa / c;
            if (Math.abs(c) < TINY) {
                c = TINY;
            }
            d = 1.0 / d;
            double delta = d * c;
            h *= delta;
            if (Math.abs(delta - 1.0) < 1e-16) {
                break;
            }
        }
        return h;
    }

    /**
     * Regularized incomplete beta I_x(a, b), given x and y = 1 − x separately so that a caller
     * who knows y to full precision (x close to 1) does not lose it.
     */
    static double betaI(double a, double b, double x, double y) {
        if (x <= 0) {
            return 0.0;
        }
        if (y <= 0) {
            return 1.0;
        }
        double logFront = a * Math.log(x) + b * Math.log(y) - lbeta(a, b);
        if (x < (a + 1.0) / (a + b + 2.0)) {
            return Math.exp(logFront) * betaFraction(a, b, x) / a;
        }
        return 1.0 - Math.exp(logFront) * betaFraction(b, a, y) / b;
    }

    /** Regularized incomplete beta I_x(a, b) for 0 <= x <= 1. */
    public static double betaI(double a, double b, double x) {
        return betaI(a, b, x, 1.0 - x);
    }

    /** Two-sided Student t p-value 2·P(T > |t|) with {@code df} (> 0, not necessarily integral) degrees of freedom. */
    public static double studentTwoSided(double t, double df) {
        if (Double.isNaN(t) || Double.isNaN(df)) {
            return Double.NaN;
        }
        if (Double.isInfinite(t)) {
            return 0.0;
        }
        double t2 = t * t;
        // 2·sf(|t|) = I_{df/(df+t²)}(df/2, 1/2); both arguments written without cancellation.
        double x = df / (df + t2);
        double y = t2 / (df + t2);
        return betaI(df / 2.0, 0.5, x, y);
    }

    // ------------------------------------------------------------------ normal quantile

    /**
     * z = Φ⁻¹((1 + level)/2), the half-width of a two-sided normal interval with coverage
     * {@code level} (0 < level < 1). Bisection on the erf / erfc relation P(½, z²/2) = level,
     * which is monotone and evaluated to full relative precision on either side of ½, so the
     * root is found to the last bits without a starting approximation.
     */
    public static double normalHalfWidth(double level) {
        if (!(level > 0 && level < 1)) {
            return Double.NaN;
        }
        boolean upper = level > 0.5;
        double target = upper ? 1.0 - level : level; // 1 − level is exact for level >= 1/2
        double lo = 0.0;
        double hi = 40.0;
        for (int i = 0; i < 2000; i++) {
            double mid = 0.5 * (lo + hi);
            if (mid <= lo || mid >= hi) {
                break;
            }
            double x = 0.5 * mid * mid;
            boolean below = upper ? gammaQ(0.5, x) > target : gammaP(0.5, x) < target;
            if (below) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        return 0.5 * (lo + hi);
    }

    /** The standard normal quantile Φ⁻¹(p), 0 < p < 1. */
    public static double normalQuantile(double p) {
        if (!(p > 0 && p < 1)) {
            return Double.NaN;
        }
        if (p == 0.5) {
            return 0.0;
        }
        // Φ⁻¹(p) = ± halfWidth(|2p − 1|); 2p − 1 is exact for p in [1/4, 1] and p < 1/4 uses 1 − 2p.
        double level = p > 0.5 ? 2.0 * p - 1.0 : 1.0 - 2.0 * p;
        double z = normalHalfWidth(level);
        return p > 0.5 ? z : -z;
    }
}
