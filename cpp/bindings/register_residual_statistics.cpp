// Family `residual_statistics`: residual_mean, residual_variance and the fused compute_metrics.
#include "bindings.hpp"

namespace dynval::bindings {

namespace {
py::array_t<double> vec(const Eigen::ArrayXd& a) { return py::cast(Eigen::VectorXd(a.matrix())); }
}  // namespace

void register_residual_statistics(py::module_& m) {
    m.def(
        "residual_mean",
        [](const RowRef& e) {
            Eigen::ArrayXd v;
            {
                py::gil_scoped_release release;
                v = dynval::residual_mean(e);
            }
            return vec(v);
        },
        py::arg("e"), "Mean of each joint's residual, (m,).");
    m.def(
        "residual_variance",
        [](const RowRef& e, py::object ddof) {
            const auto d = int_arg(ddof);
            const Eigen::ArrayXd v = python_values({{"ddof", ddof}}, [&] {
                py::gil_scoped_release release;
                return dynval::residual_variance(e, d);
            });
            return vec(v);
        },
        py::arg("e"), py::arg("ddof"), "Σ(e − ē)²/(N − ddof) per joint, (m,).");
    m.def(
        "compute_metrics",
        [](const RowRef& meas, const RowRef& pred, py::object n_params, py::object ddof, py::object noise_model) {
            const auto p = int_arg(n_params);
            const auto d = int_arg(ddof);
            const auto nm = option_arg<dynval::noise_model>(noise_model);
            const ValidationMetrics r =
                python_values({{"n_params", n_params}, {"ddof", ddof}, {"noise_model", noise_model}}, [&] {
                    py::gil_scoped_release release;
                    return dynval::compute_metrics(meas, pred, p, d, nm);
                });
            py::dict out;
            out["n_samples"] = r.n_samples;
            out["n_joints"] = r.n_joints;
            out["n_params"] = r.n_params;
            out["sse"] = vec(r.sse);
            out["rmse"] = vec(r.rmse);
            out["max_abs_error"] = vec(r.max_abs_error);
            out["vaf"] = vec(r.vaf);
            out["fit_percent"] = vec(r.fit_percent);
            out["r2"] = vec(r.r2);
            out["residual_mean"] = vec(r.residual_mean);
            out["residual_variance"] = vec(r.residual_variance);
            out["constant_target"] = bool_array(r.constant_target);
            out["sse_total"] = r.sse_total;
            out["rmse_per_element"] = r.rmse_per_element;
            out["rmse_per_sample"] = r.rmse_per_sample;
            out["max_abs_error_pooled"] = r.max_abs_error_pooled;
            out["vaf_pooled"] = r.vaf_pooled;
            out["fit_percent_pooled"] = r.fit_percent_pooled;
            out["r2_pooled"] = r.r2_pooled;
            out["constant_target_pooled"] = r.constant_target_pooled;
            out["rmse_uniform_average"] = r.rmse_uniform_average;
            out["vaf_uniform_average"] = r.vaf_uniform_average;
            out["fit_percent_uniform_average"] = r.fit_percent_uniform_average;
            out["r2_uniform_average"] = r.r2_uniform_average;
            out["vaf_variance_weighted"] = r.vaf_variance_weighted;
            out["fit_percent_variance_weighted"] = r.fit_percent_variance_weighted;
            out["r2_variance_weighted"] = r.r2_variance_weighted;
            out["aic"] = r.aic;
            out["bic"] = r.bic;
            out["aicc"] = r.aicc;
            out["fpe"] = r.fpe;
            out["naic"] = r.naic;
            return out;
        },
        py::arg("meas"), py::arg("pred"), py::arg("n_params"), py::arg("ddof"), py::arg("noise_model"),
        "Every point metric, aggregation and information criterion in one pass (dict).");
}

}  // namespace dynval::bindings
