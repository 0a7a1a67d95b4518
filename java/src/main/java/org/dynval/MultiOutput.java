package org.dynval;

/** How per-joint values are aggregated (the contract's {@code multioutput}). */
public enum MultiOutput {
    /** All N·m values flattened, one global mean (the lesson). */
    POOLED("pooled"),
    /** One value per joint. */
    RAW_VALUES("raw_values"),
    /** Mean of the per-joint values (scikit-learn). */
    UNIFORM_AVERAGE("uniform_average"),
    /** Per-joint values weighted by each joint's total sum of squares. */
    VARIANCE_WEIGHTED("variance_weighted");

    private final String contractName;

    MultiOutput(String contractName) {
        this.contractName = contractName;
    }

    public String contractName() {
        return contractName;
    }
}
