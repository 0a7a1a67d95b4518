package org.dynval;

import java.util.Arrays;

/**
 * A metric that is either one number aggregating the joints ({@code pooled},
 * {@code uniform_average}, {@code variance_weighted}) or one number per joint
 * ({@code raw_values}), like the C++ core's {@code metric_value}.
 */
public final class MetricValue {
    private final boolean perJoint;
    private final double value;
    private final double[] values;

    private MetricValue(boolean perJoint, double value, double[] values) {
        this.perJoint = perJoint;
        this.value = value;
        this.values = values;
    }

    static MetricValue aggregate(double value) {
        return new MetricValue(false, value, null);
    }

    static MetricValue perJoint(double[] values) {
        return new MetricValue(true, Double.NaN, values.clone());
    }

    /** True for {@code raw_values}: {@link #values()} holds one value per joint. */
    public boolean isPerJoint() {
        return perJoint;
    }

    /** The aggregate value; throws for a per-joint result. */
    public double value() {
        if (perJoint) {
            throw new IllegalStateException("a per-joint metric has no single value; use values()");
        }
        return value;
    }

    /** The per-joint values {@code (m,)}; throws for an aggregate. */
    public double[] values() {
        if (!perJoint) {
            throw new IllegalStateException("an aggregated metric has no per-joint values; use value()");
        }
        return values.clone();
    }

    @Override
    public String toString() {
        return perJoint ? Arrays.toString(values) : Double.toString(value);
    }
}
