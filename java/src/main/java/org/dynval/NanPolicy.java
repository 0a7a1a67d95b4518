package org.dynval;

/** What a function does with NaN, ±inf and values beyond |x| = 1e144 in its data. */
public enum NanPolicy {
    /** The first such value raises NonFiniteInput. */
    RAISE("raise"),
    /** Rows holding one are deleted and a segment break is inserted where they were. */
    OMIT("omit");

    private final String contractName;

    NanPolicy(String contractName) {
        this.contractName = contractName;
    }

    public String contractName() {
        return contractName;
    }
}
