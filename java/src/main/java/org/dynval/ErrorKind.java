package org.dynval;

/** The six language-neutral error kinds of the contract (docs/contract.md §2). */
public enum ErrorKind {
    INVALID_TYPE("InvalidType"),
    INVALID_SHAPE("InvalidShape"),
    SHAPE_MISMATCH("ShapeMismatch"),
    TOO_FEW_SAMPLES("TooFewSamples"),
    NON_FINITE_INPUT("NonFiniteInput"),
    INVALID_PARAMETER("InvalidParameter");

    private final String contractName;

    ErrorKind(String contractName) {
        this.contractName = contractName;
    }

    /** The kind as the contract, the corpus and the protocol spell it, e.g. {@code InvalidShape}. */
    public String contractName() {
        return contractName;
    }
}
