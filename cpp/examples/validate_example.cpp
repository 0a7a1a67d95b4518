// Validating an identified robot dynamic model in C++ with dynval (no Python involved).
//
// A controller or a ROS node holds measured torques and the model's predictions as (N, m)
// matrices (samples in rows, joints in columns). Here both are synthesised: a 3-joint robot,
// 2000 samples, a model whose joint 2 misses a friction term.
#include <dynval/dynval.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

int main() {
    const Eigen::Index n = 2000, m = 3;
    const long long n_params = 12;  // parameters of the identified model
    Eigen::MatrixXd tau_meas(n, m), tau_pred(n, m);
    std::mt19937_64 gen(42);
    std::normal_distribution<double> sensor(0.0, 0.05);  // white measurement noise
    for (Eigen::Index k = 0; k < n; ++k) {
        const double t = 0.005 * static_cast<double>(k);
        for (Eigen::Index j = 0; j < m; ++j) {
            const double qd = std::cos(t * (1.0 + 0.3 * static_cast<double>(j)));
            const double model = 5.0 * std::sin(t * (1.0 + 0.5 * static_cast<double>(j))) + 2.0 * qd;
            const double noise = sensor(gen);
            const double friction = j == 2 ? 0.8 * std::tanh(20.0 * qd) : 0.0;  // unmodelled on joint 2
            tau_pred(k, j) = model;
            tau_meas(k, j) = model + friction + noise;
        }
    }

    // Every point metric and the information criteria in one pass (the lesson's computeMetricsCpp).
    const dynval::ValidationMetrics r = dynval::compute_metrics(tau_meas, tau_pred, n_params);
    std::printf("pooled: rmse_per_element = %.6f  vaf = %.3f %%  fit = %.3f %%  r2 = %.6f\n", r.rmse_per_element,
                r.vaf_pooled, r.fit_percent_pooled, r.r2_pooled);
    std::printf("criteria (pooled noise): aic = %.3f  bic = %.3f\n", r.aic, r.bic);
    for (Eigen::Index j = 0; j < m; ++j)
        std::printf("joint %ld: rmse = %.5f  r2 = %.5f  vaf = %.3f %%\n", static_cast<long>(j), r.rmse(j), r.r2(j),
                    r.vaf(j));

    // Are the residuals white? Autocorrelation against the 95 % band, and Ljung–Box at lag 20.
    const Eigen::MatrixXd e = tau_meas - tau_pred;
    const auto rho = dynval::autocorrelation(e, 20);
    const double band = dynval::confidence_band(n);
    const auto lb = dynval::ljung_box(e, std::vector<long long>{20});
    for (Eigen::Index j = 0; j < m; ++j) {
        int outside = 0;
        for (Eigen::Index lag = 1; lag <= 20; ++lag) outside += std::abs(rho(lag, j)) > band;
        std::printf("joint %ld: %d of 20 lags outside ±%.4f, Ljung-Box Q(20) = %.1f, log p = %.1f\n",
                    static_cast<long>(j), outside, band, lb.statistic(0, j), lb.log_pvalue(0, j));
    }

    // Streaming: a log too large for memory is read in blocks (here 500 rows at a time); the
    // lag accumulator gives the same autocorrelation and Ljung–Box statistic. Accumulators of
    // consecutive parts (other files, other machines) combine with merge().
    dynval::lag_accumulator stream(m, 20);
    for (Eigen::Index start = 0; start < n; start += 500)
        stream.update(e.middleRows(start, std::min<Eigen::Index>(500, n - start)));
    const auto lb_streamed = dynval::ljung_box(stream, std::vector<long long>{20});
    std::printf("streamed: Ljung-Box Q(20) of joint 0 = %.1f (in memory: %.1f)\n", lb_streamed.statistic(0, 0),
                lb.statistic(0, 0));

    // Errors carry the contract's kind and message.
    try {
        dynval::r2(tau_meas, tau_pred.topRows(10));
    } catch (const dynval::input_error& err) {
        std::printf("%s: %s\n", dynval::kind_name(err.kind()), err.what());
    }
    return 0;
}
