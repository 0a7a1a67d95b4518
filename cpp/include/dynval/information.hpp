// Information criteria (contract §3.7): AIC, BIC, AICc, FPE and normalised AIC with an explicit
// noise model. Constants of the Gaussian log-likelihood are dropped (the lesson's form).
#pragma once

#include "accumulator.hpp"
#include "errors.hpp"
#include "options.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Core>

#include <cmath>
#include <limits>

namespace dynval {

/// AIC, BIC, AICc, FPE and nAIC; `n_obs` is the n used in ln n, AICc and FPE.
struct information_criteria_result {
    double aic = 0.0;
    double bic = 0.0;
    double aicc = 0.0;
    double fpe = 0.0;
    double naic = 0.0;
    long long n_obs = 0;
    double fit_term = 0.0;  ///< F of the contract's table (−inf when the residual is degenerate)
};

namespace detail {

/// The criteria from the fit term F, n (for ln n, AICc, FPE), N_vec (nAIC), the σ² "size" S and p,
/// in the order of the contract (§3.7) everywhere. p >= n − 1 leaves AICc and FPE undefined: NaN.
inline information_criteria_result criteria_from_fit(double fit_term, long long n, double n_vec, double size,
                                                     long long n_params) {
    const double p = static_cast<double>(n_params);
    const double nd = static_cast<double>(n);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    information_criteria_result r;
    r.n_obs = n;
    r.fit_term = fit_term;
    r.aic = fit_term + 2.0 * p;
    r.bic = fit_term + p * std::log(nd);
    const bool defined = n_params < n - 1;
    r.aicc = defined ? r.aic + 2.0 * p * (p + 1.0) / (nd - p - 1.0) : nan;
    r.fpe = defined ? size * (1.0 + p / nd) / (1.0 - p / nd) : nan;
    r.naic = fit_term / n_vec + 2.0 * p / nd;
    return r;
}

/// ln det of a symmetric positive semi-definite matrix; −inf when it is numerically singular.
/// Singular means λ_min ≤ m·ε·λ_max (numpy's matrix_rank tolerance) or λ_max = 0, decided on the
/// eigenvalues so that both backends call the same near-singular covariance singular (an LDLT or LU
/// pivot test rounds differently from one library to the next).
inline double log_det_psd(const Eigen::MatrixXd& sigma) {
    const double ninf = -std::numeric_limits<double>::infinity();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(sigma, Eigen::EigenvaluesOnly);
    if (solver.info() != Eigen::Success) return ninf;
    const auto lambda = solver.eigenvalues().array();  // ascending
    const double largest = lambda(lambda.size() - 1);
    const double tolerance = static_cast<double>(sigma.rows()) * std::numeric_limits<double>::epsilon() * largest;
    if (!(largest > 0.0) || lambda(0) <= tolerance) return ninf;
    return lambda.log().sum();
}

/// Criteria of a noise model from the accumulated moments (the gram matrix is needed for `full`).
inline information_criteria_result criteria_from_moments(const joint_moments& mo, long long n_params,
                                                         noise_model model) {
    const double ninf = -std::numeric_limits<double>::infinity();
    const double ln2 = std::log(2.0);
    const long long n = static_cast<long long>(mo.n_samples);
    const long long m = static_cast<long long>(mo.n_joints);
    const double nd = static_cast<double>(n);
    switch (model) {
        case noise_model::pooled: {
            const long long nm = n * m;
            const double nmd = static_cast<double>(nm);
            // ln(SSE/nm) from the scaled sum: exact exponent, no underflow of SSE itself.
            const auto sse = mo.sse_pooled();
            const double log_s = std::log(sse.sum / nmd) + 2.0 * sse.exp * ln2;
            const double f = sse.sum > 0.0 ? nmd * log_s : ninf;
            return criteria_from_fit(f, nm, nmd, sse.sum > 0.0 ? std::ldexp(sse.sum / nmd, 2 * sse.exp) : 0.0, n_params);
        }
        case noise_model::per_joint: {
            bool degenerate = false;
            double log_sum = 0.0;
            for (Index j = 0; j < mo.n_joints; ++j) {
                if (!(mo.sse(j) > 0.0)) degenerate = true;
                log_sum += std::log(mo.sse(j) / nd) + 2.0 * mo.e_exp(j) * ln2;
            }
            // Π_j SSE_j/N as exp(Σ ln): a running product overflows or underflows part-way
            // depending on the order of the joints (2.9e99 in one order, inf in another).
            const double f = degenerate ? ninf : nd * log_sum;
            return criteria_from_fit(f, n, nd, degenerate ? 0.0 : std::exp(log_sum), n_params);
        }
        case noise_model::full: {
            const Eigen::MatrixXd sigma = mo.residual_gram / nd;
            bool degenerate = !(mo.sse > 0.0).all();
            // Σ̂ of e·2^-k is Σ̂·4^-k: ln det gains 2k·m·ln 2.
            const double logdet = degenerate ? ninf : log_det_psd(sigma) + 2.0 * mo.gram_exp * ln2 * static_cast<double>(m);
            degenerate = degenerate || std::isinf(logdet);
            const double f = degenerate ? ninf : nd * logdet;
            return criteria_from_fit(f, n, nd, degenerate ? 0.0 : std::exp(logdet), n_params);
        }
    }
    return {};
}

}  // namespace detail

/// Criteria from a residual sum of squares (contract §3.7): σ̂² = rss / n_obs.
///
/// Throws InvalidParameter for rss < 0 or non-finite, n_obs < 1, n_params < 0 or
/// n_params >= n_obs − 1 (AICc and FPE are undefined there).
inline information_criteria_result information_criteria(double rss, long long n_obs, long long n_params) {
    if (!std::isfinite(rss) || rss < 0.0) detail::throw_parameter("rss", "a finite number >= 0", value_text(rss));
    const long long n = detail::require_int(n_obs, "n_obs", 1, -1, "an integer with n_obs >= 1");
    const long long p = detail::require_int(n_params, "n_params", 0, -1, "an integer with n_params >= 0");
    if (!(p < n - 1))
        detail::throw_parameter("n_params", "less than n_obs - 1 = " + std::to_string(n - 1), value_text(p));
    const double nd = static_cast<double>(n);
    const double r = rss;
    const double sigma2 = r / nd;
    const double f = r > 0.0 ? nd * std::log(sigma2) : -std::numeric_limits<double>::infinity();
    return detail::criteria_from_fit(f, n, nd, r > 0.0 ? sigma2 : 0.0, p);
}

/// Criteria of `tau_meas` against `tau_pred` under a noise model (contract §3.7 table).
template <class A, class B>
information_criteria_result criteria(const Eigen::MatrixBase<A>& tau_meas, const Eigen::MatrixBase<B>& tau_pred,
                                     long long n_params, noise_model model = noise_model::pooled,
                                     const std::string& function = "criteria") {
    detail::check_columns(tau_meas.rows(), tau_meas.cols(), "tau_meas");
    detail::check_columns(tau_pred.rows(), tau_pred.cols(), "tau_pred");
    detail::check_same_shape(tau_meas.rows(), tau_meas.cols(), tau_pred.rows(), tau_pred.cols(), "tau_meas",
                             "tau_pred");
    detail::check_min_samples(tau_meas.rows(), 2, function);
    const bool full = model == noise_model::full;
    joint_moments mo = accumulate(tau_meas, tau_pred, full);
    mo.throw_if_nonfinite();
    mo = rescale_tiny(std::move(mo), tau_meas, tau_pred, full);
    const long long p = detail::require_int(n_params, "n_params", 0, -1, "an integer with n_params >= 0");
    const noise_model nm = detail::require_option(model, "noise_model");
    return detail::criteria_from_moments(mo, p, nm);
}

/// AIC of `tau_meas` against `tau_pred`.
template <class A, class B>
double aic(const Eigen::MatrixBase<A>& tau_meas, const Eigen::MatrixBase<B>& tau_pred,
           long long n_params, noise_model model = noise_model::pooled) {
    return criteria(tau_meas, tau_pred, n_params, model, "aic").aic;
}

/// BIC of `tau_meas` against `tau_pred`.
template <class A, class B>
double bic(const Eigen::MatrixBase<A>& tau_meas, const Eigen::MatrixBase<B>& tau_pred,
           long long n_params, noise_model model = noise_model::pooled) {
    return criteria(tau_meas, tau_pred, n_params, model, "bic").bic;
}

}  // namespace dynval
