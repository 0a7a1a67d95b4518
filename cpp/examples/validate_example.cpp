// Validating an identified robot dynamic model in C++ with dynval (no Python involved).
//
// A controller or a ROS node holds measured torques and the model's predictions as (N, m)
// matrices (samples in rows, joints in columns). Here both are synthesised: a 3-joint robot,
// 2000 samples, a model whose joint 2 misses a friction term.
#include <dynval/dynval.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
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

    // Streaming a log from a file: the robot writes (tau_meas, tau_pred) rows as raw float64
    // (row-major, 2m numbers per sample); a file larger than memory is read a block of rows at a
    // time. joint_accumulator gives every point metric and lag_accumulator the autocorrelation and
    // Ljung–Box statistic, equal to the in-memory results. Accumulators of consecutive parts (other
    // files, other machines) combine with merge().
    const std::string path = (std::filesystem::temp_directory_path() / "dynval_example_log.f64").string();
    {
        std::ofstream out(path, std::ios::binary);
        for (Eigen::Index k = 0; k < n; ++k)
            for (const Eigen::MatrixXd* a : {&tau_meas, &tau_pred})
                for (Eigen::Index j = 0; j < m; ++j) {
                    const double v = (*a)(k, j);
                    out.write(reinterpret_cast<const char*>(&v), sizeof v);
                }
    }
    using Rows = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    const Eigen::Index block = 500;
    Rows buffer(block, 2 * m);
    dynval::joint_accumulator moments(m);
    dynval::lag_accumulator lags(m, 20);
    std::ifstream in(path, std::ios::binary);
    for (;;) {
        in.read(reinterpret_cast<char*>(buffer.data()), static_cast<std::streamsize>(sizeof(double) * buffer.size()));
        const Eigen::Index rows = static_cast<Eigen::Index>(in.gcount()) / static_cast<Eigen::Index>(sizeof(double) * 2 * m);
        if (rows == 0) break;
        const auto meas = buffer.topLeftCorner(rows, m), pred = buffer.block(0, m, rows, m);
        moments.update(meas, pred);
        lags.update(meas - pred);
    }
    std::remove(path.c_str());
    const auto streamed = dynval::metrics_from_moments(moments.result(), n_params, 1, dynval::noise_model::pooled);
    const auto lb_streamed = dynval::ljung_box(lags, std::vector<long long>{20});
    std::printf("streamed from %s in blocks of %ld rows: rmse_per_element = %.6f (in memory %.6f), "
                "Ljung-Box Q(20) of joint 0 = %.1f (in memory %.1f)\n",
                path.c_str(), static_cast<long>(block), streamed.rmse_per_element, r.rmse_per_element,
                lb_streamed.statistic(0, 0), lb.statistic(0, 0));

    // Errors carry the contract's kind and message.
    try {
        dynval::r2(tau_meas, tau_pred.topRows(10));
    } catch (const dynval::input_error& err) {
        std::printf("%s: %s\n", dynval::kind_name(err.kind()), err.what());
    }
    return 0;
}
