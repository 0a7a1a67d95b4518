package org.dynval;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertTrue;

import org.junit.jupiter.api.Test;
import org.junit.jupiter.params.ParameterizedTest;
import org.junit.jupiter.params.provider.CsvSource;

/**
 * The special functions against values computed once with mpmath 1.3.0 at 50 significant digits
 * (mp.dps = 50) and rounded to float64: {@code mpmath.loggamma(x)},
 * {@code mpmath.gammainc(a, x, mpmath.inf, regularized=True)} (upper) and
 * {@code mpmath.gammainc(a, 0, x, regularized=True)} (lower), {@code mpmath.betainc(a, b, 0, x,
 * regularized=True)}, and {@code mpmath.sqrt(2) * mpmath.erfinv(level)}. scipy 1.17.1's
 * {@code chi2.logsf} returns -inf for the deep-tail cases below, which is why the port has a
 * log-space continued fraction of its own.
 */
class SpecialTest {

    private static void assertRelative(double expected, double actual, double rel) {
        double tol = rel * Math.abs(expected);
        assertTrue(Math.abs(actual - expected) <= tol,
                () -> "expected " + expected + ", got " + actual + " (rel. error "
                        + Math.abs(actual - expected) / Math.abs(expected) + ")");
    }

    @ParameterizedTest
    @CsvSource({
        "0.5, 0.5723649429247001",
        "1.5, -0.12078223763524522",
        "3.7, 1.428072326665388",
        "14.9, 24.924132002217277",
        "15.0, 25.19122118273868",
        "100.25, 360.28455963776423",
        "2500.5, 17061.03394900727",
        "1000000.0, 12815504.569147611",
    })
    void logGammaMatchesMpmath(double x, double expected) {
        // ln Γ enters every p-value as the logarithm of a factor: its absolute error (relative
        // where |ln Γ| > 1) is the relative error it gives the p-value.
        double actual = Special.lgamma(x);
        assertEquals(expected, actual, 1e-14 * Math.max(1.0, Math.abs(expected)));
    }

    @Test
    void logGammaAtItsZeros() {
        assertEquals(0.0, Special.lgamma(1.0), 1e-14);
        assertEquals(0.0, Special.lgamma(2.0), 1e-14);
    }

    @ParameterizedTest
    @CsvSource({
        "0.5, 0.1, 0.654720846018577, 0.345279153981423",
        "0.5, 2.0, 0.04550026389635842, 0.9544997361036416",
        "1.0, 3.0, 0.049787068367863944, 0.950212931632136",
        "2.5, 1.0, 0.8491450360846097, 0.15085496391539036",
        "5.0, 5.5, 0.35751800242792553, 0.6424819975720745",
        "10.0, 30.0, 7.121750862815577e-06, 0.9999928782491372",
        "25.0, 20.0, 0.8432273781737623, 0.15677262182623772",
        "0.5, 700.0, 2.1010145162642176e-306, 1.0",
    })
    void regularizedIncompleteGammaMatchesMpmath(double a, double x, double upper, double lower) {
        assertRelative(upper, Special.gammaQ(a, x), 1e-13);
        assertRelative(lower, Special.gammaP(a, x), 1e-13);
    }

    @Test
    void incompleteGammaEdges() {
        assertEquals(1.0, Special.gammaQ(3.0, 0.0));
        assertEquals(0.0, Special.gammaP(3.0, 0.0));
        assertEquals(0.0, Special.gammaQ(3.0, Double.POSITIVE_INFINITY));
        assertTrue(Double.isNaN(Special.gammaQ(3.0, Double.NaN)));
        assertTrue(Double.isNaN(Special.gammaQ(-1.0, 2.0)));
    }

    /** log p-values far below 1e-280, where the p-value itself is subnormal or 0. */
    @ParameterizedTest
    @CsvSource({
        "1500.0, 10, -726.6924205661536",
        "2000.0, 3, -996.4248404973332",
        "5000.0, 50, -2366.9979826721164",
        "100000.0, 20, -49915.42364290779",
    })
    void chiSquaredLogSurvivalInTheDeepTail(double q, int df, double expected) {
        double logp = Special.chi2LogSf(q, df);
        assertTrue(Double.isFinite(logp));
        assertRelative(expected, logp, 1e-13);
        assertTrue(Special.chi2Sf(q, df) < Special.LOG_SF_SWITCH);
    }

    @Test
    void chiSquaredSurvivalOfSubnormalProbability() {
        // mpmath: 2.52052905...e-316 (subnormal: only a few digits are representable).
        assertRelative(2.52052905e-316, Special.chi2Sf(1500.0, 10), 1e-7);
    }

    @Test
    void chiSquaredModerateValuesAgreeWithTheLogarithm() {
        // chi2.sf(3.84, 1) = Q(1/2, 1.92), mpmath: 0.050043521248705106
        assertRelative(0.050043521248705106, Special.chi2Sf(3.84, 1), 1e-13);
        assertRelative(Math.log(0.050043521248705106), Special.chi2LogSf(3.84, 1), 1e-13);
        assertEquals(1.0, Special.chi2Sf(0.0, 4));
        assertTrue(Double.isNaN(Special.chi2Sf(Double.NaN, 4)));
    }

    @ParameterizedTest
    @CsvSource({
        "0.3, 4, 0.7791214282774597",
        "2.0, 10, 0.07338803477074037",
        "-3.5, 7.5, 0.00894887198007934",
        "12.0, 999, 4.34310390771625e-31",
        "1.5, 999, 0.13393035471128498",
        "40.0, 3, 3.4380680789158526e-05",
    })
    void studentTwoSidedMatchesMpmath(double t, double df, double expected) {
        // two-sided p = I_{df/(df+t²)}(df/2, 1/2)
        assertRelative(expected, Special.studentTwoSided(t, df), 1e-12);
    }

    @Test
    void studentEdges() {
        assertEquals(0.0, Special.studentTwoSided(Double.POSITIVE_INFINITY, 5));
        assertEquals(1.0, Special.studentTwoSided(0.0, 5));
        assertTrue(Double.isNaN(Special.studentTwoSided(Double.NaN, 5)));
    }

    @ParameterizedTest
    @CsvSource({
        "2.0, 3.0, 0.4, 0.5248",
        "0.5, 0.5, 0.9, 0.7951672353008665",
        "50.0, 0.5, 0.97, 0.08169933372182263",
    })
    void incompleteBetaMatchesMpmath(double a, double b, double x, double expected) {
        assertRelative(expected, Special.betaI(a, b, x), 1e-13);
    }

    @ParameterizedTest
    @CsvSource({
        "0.5, 0.6744897501960817",
        "0.9, 1.6448536269514729",
        "0.95, 1.9599639845400538",
        "0.99, 2.5758293035489004",
        "0.999999, 4.891638475692932",
        "1e-06, 1.2533141373158284e-06",
        "0.3, 0.3853204664075676",
    })
    void normalHalfWidthMatchesMpmath(double level, double expected) {
        assertRelative(expected, Special.normalHalfWidth(level), 1e-14);
    }

    @Test
    void normalQuantileIsOddAndCentred() {
        assertEquals(0.0, Special.normalQuantile(0.5));
        assertRelative(1.9599639845400538, Special.normalQuantile(0.975), 1e-13);
        assertRelative(-1.9599639845400538, Special.normalQuantile(0.025), 1e-13);
    }
}
