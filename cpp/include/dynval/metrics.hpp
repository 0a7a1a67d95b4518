// Point metrics (contract §3.1, §3.2), residual mean/variance (§3.3) and the fused
// `compute_metrics`, the lesson's computeMetricsCpp (§7) with every aggregation of the contract.
//
// Each function makes one pass over the data through joint_accumulator; the checks run in the
// contract's order: shape -> size -> finiteness (found during the pass) -> parameters.
#pragma once

#include "accumulator.hpp"
#include "errors.hpp"
#include "information.hpp"
#include "options.hpp"

#include <Eigen/Core>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace dynval {

/// A metric value: one number (`pooled`, `uniform_average`, `variance_weighted`) or one per
/// joint (`raw_values`).
struct metric_value {
    bool per_joint = false;
    double value = 0.0;       ///< the aggregate, when !per_joint
    Eigen::ArrayXd values;    ///< shape (m,), when per_joint
};

/// Everything the lesson's computeMetricsCpp returns, and the rest of the contract's point
/// metrics, from one pass. There is no bare `rmse`: pooled RMSE comes in both conventions.
struct ValidationMetrics {
    long long n_samples = 0, n_joints = 0, n_params = 0;
    // per joint, shape (m,)
    Eigen::ArrayXd sse, rmse, max_abs_error, vaf, fit_percent, r2, residual_mean, residual_variance;
    std::vector<bool> constant_target;
    // pooled over all N·m values (the lesson)
    double sse_total = 0, rmse_per_element = 0, rmse_per_sample = 0, max_abs_error_pooled = 0;
    double vaf_pooled = 0, fit_percent_pooled = 0, r2_pooled = 0;
    bool constant_target_pooled = false;
    // aggregates over joints
    double rmse_uniform_average = 0, vaf_uniform_average = 0, fit_percent_uniform_average = 0,
           r2_uniform_average = 0;
    double vaf_variance_weighted = 0, fit_percent_variance_weighted = 0, r2_variance_weighted = 0;
    // information criteria of the chosen noise model (constants dropped)
    double aic = 0, bic = 0, aicc = 0, fpe = 0, naic = 0;
};

namespace detail {

constexpr double nan_v = std::numeric_limits<double>::quiet_NaN();
constexpr double ninf_v = -std::numeric_limits<double>::infinity();

/// Degenerate rule of §3.2: a constant target gives nan when exact, −inf otherwise.
inline double normalized(bool constant, bool exact, double good) { return constant ? (exact ? nan_v : ninf_v) : good; }


inline Eigen::Array<bool, Eigen::Dynamic, 1> constant_joints(const joint_moments& mo) {
    return mo.tau_min == mo.tau_max;
}

inline Eigen::ArrayXd vaf_joints(const joint_moments& mo) {
    Eigen::ArrayXd v(mo.n_joints);
    for (Index j = 0; j < mo.n_joints; ++j)
        v(j) = normalized(mo.tau_min(j) == mo.tau_max(j), mo.e_min(j) == mo.e_max(j),
                          100.0 * (1.0 - joint_moments::ratio(mo.e_m2_of(j), mo.tau_m2_of(j))));
    return v;
}

inline Eigen::ArrayXd fit_joints(const joint_moments& mo) {
    Eigen::ArrayXd v(mo.n_joints);
    for (Index j = 0; j < mo.n_joints; ++j)
        v(j) = normalized(mo.tau_min(j) == mo.tau_max(j), mo.sse(j) == 0.0,
                          100.0 * (1.0 - std::sqrt(joint_moments::ratio(mo.sse_of(j), mo.tau_m2_of(j)))));
    return v;
}

inline Eigen::ArrayXd r2_joints(const joint_moments& mo) {
    Eigen::ArrayXd v(mo.n_joints);
    for (Index j = 0; j < mo.n_joints; ++j)
        v(j) = normalized(mo.tau_min(j) == mo.tau_max(j), mo.sse(j) == 0.0,
                          1.0 - joint_moments::ratio(mo.sse_of(j), mo.tau_m2_of(j)));
    return v;
}

inline bool pooled_constant(const joint_moments& mo) { return mo.tau_min.minCoeff() == mo.tau_max.maxCoeff(); }

inline double vaf_pooled(const joint_moments& mo) {
    return normalized(pooled_constant(mo), mo.e_min.minCoeff() == mo.e_max.maxCoeff(),
                      100.0 * (1.0 - joint_moments::ratio(mo.pooled_e_m2(), mo.pooled_tau_m2())));
}

inline double fit_pooled(const joint_moments& mo) {
    const auto sse = mo.sse_pooled();
    return normalized(pooled_constant(mo), sse.sum == 0.0,
                      100.0 * (1.0 - std::sqrt(joint_moments::ratio(sse, mo.pooled_tau_m2()))));
}

inline double r2_pooled(const joint_moments& mo) {
    const auto sse = mo.sse_pooled();
    return normalized(pooled_constant(mo), sse.sum == 0.0, 1.0 - joint_moments::ratio(sse, mo.pooled_tau_m2()));
}

/// M2_j / d in the data's units: divided before scaling back, so a tiny variance keeps its digits
/// until it leaves the float64 range.
inline Eigen::ArrayXd scaled_variance(const Eigen::ArrayXd& m2, const Eigen::ArrayXi& exps, double d) {
    Eigen::ArrayXd v(m2.size());
    for (Index j = 0; j < m2.size(); ++j) v(j) = std::ldexp(m2(j) / d, 2 * exps(j));
    return v;
}

/// IEEE mean over joints (−inf or nan propagate).
inline double uniform_average(const Eigen::ArrayXd& v) { return v.sum() / static_cast<double>(v.size()); }

/// TSS-weighted mean; constant joints get weight 0 and are left out; all constant -> uniform.
/// Weights are the TSS at the largest joint's scale, so they do not all underflow together.
inline double variance_weighted(const Eigen::ArrayXd& v, const joint_moments& mo) {
    int k = std::numeric_limits<int>::min();
    for (Index j = 0; j < mo.n_joints; ++j)
        if (mo.tau_min(j) != mo.tau_max(j)) k = std::max(k, mo.tau_exp(j));
    compensated num, den;
    for (Index j = 0; j < mo.n_joints; ++j) {
        if (mo.tau_min(j) == mo.tau_max(j)) continue;
        const double w = std::ldexp(mo.tau_m2(j), 2 * (mo.tau_exp(j) - k));
        num.add(w * v(j));
        den.add(w);
    }
    if (den.value() == 0.0) return uniform_average(v);
    return num.value() / den.value();
}

template <class A, class B>
joint_moments checked_moments(const Eigen::MatrixBase<A>& meas, const Eigen::MatrixBase<B>& pred,
                              Index min_samples, const std::string& function, bool gram = false) {
    check_columns(meas.rows(), meas.cols(), "tau_meas");
    check_columns(pred.rows(), pred.cols(), "tau_pred");
    check_same_shape(meas.rows(), meas.cols(), pred.rows(), pred.cols(), "tau_meas", "tau_pred");
    check_min_samples(meas.rows(), min_samples, function);
    joint_moments mo = accumulate(meas, pred, gram);
    mo.throw_if_nonfinite();
    return rescale_tiny(std::move(mo), meas, pred, gram);
}

template <class D>
joint_moments checked_residual_moments(const Eigen::MatrixBase<D>& e, Index min_samples, const std::string& function) {
    check_columns(e.rows(), e.cols(), "e");
    check_min_samples(e.rows(), min_samples, function);
    joint_moments mo = accumulate_signal(e);
    mo.throw_if_nonfinite("e", "e");
    return rescale_tiny_signal(std::move(mo), e);
}

/// `multioutput`: one of the four names, then one this metric supports.
inline multioutput check_multioutput(multioutput mo, const std::vector<multioutput>& allowed,
                                     const std::string& function) {
    const multioutput value = require_option(mo, "multioutput");
    for (multioutput a : allowed)
        if (a == value) return value;
    std::string names;
    for (std::size_t i = 0; i < allowed.size(); ++i) {
        if (i) names += ", ";
        names += quoted(option_name(allowed[i]));
    }
    throw_parameter("multioutput", "one of " + names + " for " + function, quoted(option_name(value)));
}

inline metric_value scalar(double v) { return metric_value{false, v, {}}; }
inline metric_value per_joint(Eigen::ArrayXd v) { return metric_value{true, 0.0, std::move(v)}; }

/// vaf, fit_percent, r2 share their aggregation rules.
inline metric_value aggregate_normalized(multioutput how, const Eigen::ArrayXd& joints, double pooled,
                                         const joint_moments& mo) {
    switch (how) {
        case multioutput::pooled: return scalar(pooled);
        case multioutput::raw_values: return per_joint(joints);
        case multioutput::uniform_average: return scalar(uniform_average(joints));
        case multioutput::variance_weighted: return scalar(variance_weighted(joints, mo));
    }
    return {};
}

}  // namespace detail

/// e = tau_meas − tau_pred, row-major (N, m).
template <class A, class B>
Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> residuals(const Eigen::MatrixBase<A>& tau_meas,
                                                                                 const Eigen::MatrixBase<B>& tau_pred) {
    detail::check_columns(tau_meas.rows(), tau_meas.cols(), "tau_meas");
    detail::check_columns(tau_pred.rows(), tau_pred.cols(), "tau_pred");
    detail::check_same_shape(tau_meas.rows(), tau_meas.cols(), tau_pred.rows(), tau_pred.cols(), "tau_meas",
                             "tau_pred");
    detail::check_min_samples(tau_meas.rows(), 1, "residuals");
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> e = tau_meas - tau_pred;
    if (auto hit = first_nonfinite(tau_meas)) detail::throw_nonfinite("tau_meas", hit->row, hit->col, hit->value);
    if (auto hit = first_nonfinite(tau_pred)) detail::throw_nonfinite("tau_pred", hit->row, hit->col, hit->value);
    return e;
}

/// Sum of squared errors: `pooled` Σ SSE_j or `raw_values` SSE_j.
template <class A, class B>
metric_value sse(const Eigen::MatrixBase<A>& tau_meas, const Eigen::MatrixBase<B>& tau_pred,
                 multioutput how = multioutput::pooled) {
    const joint_moments mo = detail::checked_moments(tau_meas, tau_pred, 1, "sse");
    const multioutput h = detail::check_multioutput(how, {multioutput::pooled, multioutput::raw_values}, "sse");
    return h == multioutput::pooled ? detail::scalar(mo.sse_total()) : detail::per_joint(mo.sse_values());
}

/// Maximum absolute error, pooled or per joint.
template <class A, class B>
metric_value max_abs_error(const Eigen::MatrixBase<A>& tau_meas, const Eigen::MatrixBase<B>& tau_pred,
                           multioutput how = multioutput::pooled) {
    const joint_moments mo = detail::checked_moments(tau_meas, tau_pred, 1, "max_abs_error");
    const multioutput h =
        detail::check_multioutput(how, {multioutput::pooled, multioutput::raw_values}, "max_abs_error");
    const Eigen::ArrayXd joints = mo.max_abs_e_values();
    return h == multioutput::pooled ? detail::scalar(joints.maxCoeff()) : detail::per_joint(joints);
}

/// RMSE. `convention` (pooled only; unset = per_element): √(SSE/(N·m)) or √(SSE/N).
template <class A, class B>
metric_value rmse(const Eigen::MatrixBase<A>& tau_meas, const Eigen::MatrixBase<B>& tau_pred,
                  multioutput how = multioutput::pooled,
                  const std::optional<rmse_convention>& convention = std::nullopt) {
    const joint_moments mo = detail::checked_moments(tau_meas, tau_pred, 1, "rmse");
    const multioutput h = detail::check_multioutput(
        how, {multioutput::pooled, multioutput::raw_values, multioutput::uniform_average}, "rmse");
    rmse_convention conv = rmse_convention::per_element;
    if (convention) {
        if (h != multioutput::pooled)
            detail::throw_parameter("convention", "None unless multioutput='pooled'",
                                    option_traits<rmse_convention>::valid(*convention)
                                        ? quoted(option_name(*convention))
                                        : std::to_string(static_cast<long long>(*convention)));
        conv = detail::require_option(*convention, "convention");
    }
    const double n = static_cast<double>(mo.n_samples);
    const Eigen::ArrayXd joints = mo.rmse_values();
    switch (h) {
        case multioutput::raw_values: return detail::per_joint(joints);
        case multioutput::uniform_average: return detail::scalar(detail::uniform_average(joints));
        default: break;
    }
    const double denom = conv == rmse_convention::per_element ? n * static_cast<double>(mo.n_joints) : n;
    const auto total = mo.sse_pooled();
    return detail::scalar(std::ldexp(std::sqrt(total.sum / denom), total.exp));
}

/// Variance accounted for, in percent.
template <class A, class B>
metric_value vaf(const Eigen::MatrixBase<A>& tau_meas, const Eigen::MatrixBase<B>& tau_pred,
                 multioutput how = multioutput::pooled) {
    const joint_moments mo = detail::checked_moments(tau_meas, tau_pred, 2, "vaf");
    const multioutput h = detail::require_option(how, "multioutput");
    return detail::aggregate_normalized(h, detail::vaf_joints(mo), h == multioutput::pooled ? detail::vaf_pooled(mo) : 0.0, mo);
}

/// Normalised-RMSE fit, in percent: 100(1 − √(SSE/TSS)).
template <class A, class B>
metric_value fit_percent(const Eigen::MatrixBase<A>& tau_meas, const Eigen::MatrixBase<B>& tau_pred,
                         multioutput how = multioutput::pooled) {
    const joint_moments mo = detail::checked_moments(tau_meas, tau_pred, 2, "fit_percent");
    const multioutput h = detail::require_option(how, "multioutput");
    return detail::aggregate_normalized(h, detail::fit_joints(mo), h == multioutput::pooled ? detail::fit_pooled(mo) : 0.0, mo);
}

/// Coefficient of determination, 1 − SSE/TSS.
template <class A, class B>
metric_value r2(const Eigen::MatrixBase<A>& tau_meas, const Eigen::MatrixBase<B>& tau_pred,
                multioutput how = multioutput::pooled) {
    const joint_moments mo = detail::checked_moments(tau_meas, tau_pred, 2, "r2");
    const multioutput h = detail::require_option(how, "multioutput");
    return detail::aggregate_normalized(h, detail::r2_joints(mo), h == multioutput::pooled ? detail::r2_pooled(mo) : 0.0, mo);
}

/// Mean of each joint's residual, shape (m,).
template <class D>
Eigen::ArrayXd residual_mean(const Eigen::MatrixBase<D>& e) {
    return detail::checked_residual_moments(e, 1, "residual_mean").tau_mean_values();
}

/// Σ(e − ē_j)² / (N − ddof) per joint, shape (m,).
template <class D>
Eigen::ArrayXd residual_variance(const Eigen::MatrixBase<D>& e, long long ddof = 1) {
    const joint_moments mo = detail::checked_residual_moments(e, 2, "residual_variance");
    const long long n = mo.n_samples;
    const long long d = detail::require_int(ddof, "ddof", 0, n, "an integer with 0 <= ddof < N=" + std::to_string(n));
    return detail::scaled_variance(mo.tau_m2, mo.tau_exp, static_cast<double>(n - d));
}

/// Every point metric from accumulated moments (no checks).
inline ValidationMetrics metrics_from_moments(const joint_moments& mo, long long n_params, long long ddof,
                                              noise_model model) {
    ValidationMetrics r;
    const double n = static_cast<double>(mo.n_samples);
    r.n_samples = mo.n_samples;
    r.n_joints = mo.n_joints;
    r.n_params = n_params;
    r.sse = mo.sse_values();
    r.rmse = mo.rmse_values();
    r.max_abs_error = mo.max_abs_e_values();
    r.vaf = detail::vaf_joints(mo);
    r.fit_percent = detail::fit_joints(mo);
    r.r2 = detail::r2_joints(mo);
    r.residual_mean = mo.e_mean_values();
    r.residual_variance = detail::scaled_variance(mo.e_m2, mo.e_exp, static_cast<double>(mo.n_samples - ddof));
    r.constant_target.resize(static_cast<std::size_t>(mo.n_joints));
    for (Index j = 0; j < mo.n_joints; ++j) r.constant_target[static_cast<std::size_t>(j)] = mo.tau_min(j) == mo.tau_max(j);
    const auto total = mo.sse_pooled();
    r.sse_total = total.value();
    r.rmse_per_element = std::ldexp(std::sqrt(total.sum / (n * static_cast<double>(mo.n_joints))), total.exp);
    r.rmse_per_sample = std::ldexp(std::sqrt(total.sum / n), total.exp);
    r.max_abs_error_pooled = r.max_abs_error.maxCoeff();
    r.vaf_pooled = detail::vaf_pooled(mo);
    r.fit_percent_pooled = detail::fit_pooled(mo);
    r.r2_pooled = detail::r2_pooled(mo);
    r.constant_target_pooled = detail::pooled_constant(mo);
    r.rmse_uniform_average = detail::uniform_average(r.rmse);
    r.vaf_uniform_average = detail::uniform_average(r.vaf);
    r.fit_percent_uniform_average = detail::uniform_average(r.fit_percent);
    r.r2_uniform_average = detail::uniform_average(r.r2);
    r.vaf_variance_weighted = detail::variance_weighted(r.vaf, mo);
    r.fit_percent_variance_weighted = detail::variance_weighted(r.fit_percent, mo);
    r.r2_variance_weighted = detail::variance_weighted(r.r2, mo);
    const information_criteria_result ic = detail::criteria_from_moments(mo, n_params, model);
    r.aic = ic.aic;
    r.bic = ic.bic;
    r.aicc = ic.aicc;
    r.fpe = ic.fpe;
    r.naic = ic.naic;
    return r;
}

/// The lesson's computeMetricsCpp, fused: one pass over the data for every point metric, every
/// aggregation and the information criteria of `model`.
template <class A, class B>
ValidationMetrics compute_metrics(const Eigen::MatrixBase<A>& tau_meas, const Eigen::MatrixBase<B>& tau_pred,
                                  long long n_params, long long ddof = 1, noise_model model = noise_model::pooled) {
    const bool full = model == noise_model::full;
    const joint_moments mo = detail::checked_moments(tau_meas, tau_pred, 2, "compute_metrics", full);
    const long long p = detail::require_int(n_params, "n_params", 0, -1, "an integer with n_params >= 0");
    const long long n = mo.n_samples;
    const long long d = detail::require_int(ddof, "ddof", 0, n, "an integer with 0 <= ddof < N=" + std::to_string(n));
    const noise_model nm = detail::require_option(model, "noise_model");
    return metrics_from_moments(mo, p, d, nm);
}

}  // namespace dynval
