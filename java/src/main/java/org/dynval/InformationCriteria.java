package org.dynval;

/**
 * AIC, BIC, AICc, FPE and nAIC with the Gaussian constant dropped (contract §3.7). {@code aicc}
 * and {@code fpe} are nan when n_params >= n_obs − 1 (from {@code criteria}).
 */
public record InformationCriteria(
        double aic, double bic, double aicc, double fpe, double naic,
        long nObs, long nParams, String noiseModel) {
}
