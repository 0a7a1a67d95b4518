package org.dynval;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.io.BufferedReader;
import java.io.StringReader;
import java.io.StringWriter;
import org.junit.jupiter.api.Test;

/** A whole protocol session through {@link PortMain#serve}. */
class PortMainTest {

    private static String session(String input) throws Exception {
        StringWriter out = new StringWriter();
        int status = PortMain.serve(new BufferedReader(new StringReader(input)), out);
        assertEquals(0, status);
        return out.toString();
    }

    @Test
    void greetsDeclaresAndAnswers() throws Exception {
        String out = session(String.join("\n",
                "case norms 12 rmse multioutput=\"raw_values\" convention=none nan_policy=\"raise\"",
                "array tau_meas real 2 3 2 1.0 2.0 2.0 1.0 0.5 3.0",
                "array tau_pred real 2 3 2 1.0 2.0 2.0 1.0 0.5 3.0",
                "end",
                "case errors 4 r2 multioutput=\"pooled\"",
                "array tau_meas real 2 1 1 1.0",
                "array tau_pred real 2 1 1 1.0",
                "end",
                "case errors 5 r2 multioutput=\"pooled\"",
                "scalar tau_meas none",
                "array tau_pred real 1 2 1.0 2.0",
                "end",
                "quit", ""));
        String[] lines = out.split("\n");
        assertTrue(lines[0].startsWith("dynval-port 1 "), lines[0]);
        assertTrue(out.contains("capability cross_correlation\n"));
        assertTrue(out.contains("capability accumulate\n"));
        assertTrue(out.contains("ready\nresult value real 1 2 0.0000000000000000e+00 0.0000000000000000e+00\nend\n"), out);
        assertTrue(out.contains("error TooFewSamples r2 needs at least 2 samples, got N=1\nend\n"), out);
        assertTrue(out.contains("error InvalidType tau_meas must be an array of real numbers, got NoneType\nend\n"), out);
    }

    @Test
    void typedValues() throws Exception {
        assertEquals(null, PortMain.parseValue("none"));
        assertEquals(Boolean.TRUE, PortMain.parseValue("true"));
        assertEquals(12L, PortMain.parseValue("12"));
        assertEquals(1.0, PortMain.parseValue("1.0000000000000000e+00"));
        assertEquals("a b", PortMain.parseValue("\"a%20b\""));
        assertEquals(java.util.List.of(500L, 300L), PortMain.parseValue("[500,300]"));
        assertEquals(java.util.List.of(), PortMain.parseValue("[]"));
        assertEquals(new java.math.BigInteger("-9223372036854775809"), PortMain.parseValue("-9223372036854775809"));
    }

    @Test
    void integersAndBooleansAreWrittenAsSuch() throws Exception {
        String out = session(String.join("\n",
                "case cross_correlation 1 cross_correlation adjusted=true level=9.4999999999999996e-01 segments=none",
                "array e real 2 4 1 1 -1 2 0",
                "array regressor real 3 4 1 2 1 5 -1 5 2 5 0 5",
                "scalar max_lag 0",
                "end", ""));
        assertTrue(out.contains("result constant_mask bool 2 1 2 0 1\n"), out);
        // ρ = 1 to rounding (√R_e(0)·√R_Y(0) may round one ulp away from √(R_e(0)·R_Y(0))).
        assertTrue(out.matches("(?s).*result rho real 3 1 2 1 (1\\.0000000000000000e\\+00|9\\.99999999999999[0-9]{2}e-01) nan\n.*"), out);
    }
}
