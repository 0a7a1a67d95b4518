package org.dynval;

/** The noise model of the information criteria (contract §3.7). */
public enum NoiseModel {
    /** One σ² for all N·m residuals (the lesson). */
    POOLED("pooled"),
    /** One σ² per joint. */
    PER_JOINT("per_joint"),
    /** A full m×m covariance, not demeaned (MATLAB's multi-output convention). */
    FULL("full");

    private final String contractName;

    NoiseModel(String contractName) {
        this.contractName = contractName;
    }

    public String contractName() {
        return contractName;
    }
}
