package org.dynval;

/** Normalisation of the pooled RMSE (contract §3.1); only with {@link MultiOutput#POOLED}. */
public enum RmseConvention {
    /** √(SSE/(N·m)): the lesson's formula, and the default. */
    PER_ELEMENT("per_element"),
    /** √(SSE/N): the lesson's code. */
    PER_SAMPLE("per_sample");

    private final String contractName;

    RmseConvention(String contractName) {
        this.contractName = contractName;
    }

    public String contractName() {
        return contractName;
    }
}
