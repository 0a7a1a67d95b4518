package org.dynval;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertThrows;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.util.Locale;
import java.util.Random;
import org.junit.jupiter.api.Test;

class ProtocolNumbersTest {

    @Test
    void writesSeventeenSignificantDigits() {
        assertEquals("-4.5931701859880914e+03", ProtocolNumbers.writeReal(-4593.170185988091));
        assertEquals("4.9406564584124654e-324", ProtocolNumbers.writeReal(Double.MIN_VALUE));
        assertEquals("1.0000000000000000e+00", ProtocolNumbers.writeReal(1.0));
        assertEquals("-0.0000000000000000e+00", ProtocolNumbers.writeReal(-0.0));
        assertEquals("0.0000000000000000e+00", ProtocolNumbers.writeReal(0.0));
        assertEquals("9.4999999999999996e-01", ProtocolNumbers.writeReal(0.95));
        assertEquals("1.7976931348623157e+308", ProtocolNumbers.writeReal(Double.MAX_VALUE));
        assertEquals("1.0000000000000000e+144", ProtocolNumbers.writeReal(1e144));
    }

    @Test
    void writesNonFiniteValuesAsTheGrammarSays() {
        assertEquals("nan", ProtocolNumbers.writeReal(Double.NaN));
        assertEquals("inf", ProtocolNumbers.writeReal(Double.POSITIVE_INFINITY));
        assertEquals("-inf", ProtocolNumbers.writeReal(Double.NEGATIVE_INFINITY));
    }

    @Test
    void roundTripsEveryDouble() {
        Random random = new Random(20261123L);
        for (int i = 0; i < 20000; i++) {
            double x = Double.longBitsToDouble(random.nextLong());
            if (!Double.isFinite(x)) {
                continue;
            }
            String text = ProtocolNumbers.writeReal(x);
            assertTrue(text.matches("-?[0-9]\\.[0-9]{16}e[+-][0-9]{2,3}"), text);
            assertEquals(Double.doubleToLongBits(x), Double.doubleToLongBits(ProtocolNumbers.readReal(text)), text);
        }
    }

    @Test
    void ignoresTheDefaultLocale() {
        Locale saved = Locale.getDefault();
        try {
            Locale.setDefault(Locale.FRANCE);
            assertEquals("1.5000000000000000e+00", ProtocolNumbers.writeReal(1.5));
            assertEquals(1.5, ProtocolNumbers.readReal("1.5"));
        } finally {
            Locale.setDefault(saved);
        }
    }

    @Test
    void readsEveryFormOfTheGrammar() {
        assertTrue(Double.isNaN(ProtocolNumbers.readReal("nan")));
        assertTrue(Double.isNaN(ProtocolNumbers.readReal("-nan")));
        assertTrue(Double.isNaN(ProtocolNumbers.readReal("NaN")));
        assertTrue(Double.isNaN(ProtocolNumbers.readReal("nan(ind)")));
        assertEquals(Double.POSITIVE_INFINITY, ProtocolNumbers.readReal("Inf"));
        assertEquals(Double.POSITIVE_INFINITY, ProtocolNumbers.readReal("+infinity"));
        assertEquals(Double.NEGATIVE_INFINITY, ProtocolNumbers.readReal("-INF"));
        assertEquals(0.5, ProtocolNumbers.readReal(".5"));
        assertEquals(5.0, ProtocolNumbers.readReal("5."));
        assertEquals(1e-9, ProtocolNumbers.readReal("1e-9"));
        assertEquals(-2.5e3, ProtocolNumbers.readReal("-2.5E+3"));
    }

    @Test
    void rejectsWhatTheGrammarRejects() {
        for (String bad : new String[] {"1,5", "1.5*^-3", "0x1.8p+0", "1e", ".", "Indeterminate", "1.0d0", "1.5f", ""}) {
            assertThrows(NumberFormatException.class, () -> ProtocolNumbers.readReal(bad), bad);
        }
    }
}
