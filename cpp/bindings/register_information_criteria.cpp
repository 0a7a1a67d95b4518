// Family `information_criteria`: from an RSS, and from data under a noise model.
#include "bindings.hpp"

namespace dynval::bindings {

namespace {
py::dict criteria_dict(const information_criteria_result& r) {
    py::dict out;
    out["aic"] = r.aic;
    out["bic"] = r.bic;
    out["aicc"] = r.aicc;
    out["fpe"] = r.fpe;
    out["naic"] = r.naic;
    return out;
}
}  // namespace

void register_information_criteria(py::module_& m) {
    m.def(
        "information_criteria",
        [](py::object rss, py::object n_obs, py::object n_params) {
            return criteria_dict(python_values({{"rss", rss}, {"n_obs", n_obs}, {"n_params", n_params}}, [&] {
                return dynval::information_criteria(real_arg(rss), int_arg(n_obs), int_arg(n_params));
            }));
        },
        py::arg("rss"), py::arg("n_obs"), py::arg("n_params"), "aic, bic, aicc, fpe, naic with σ̂² = rss/n_obs.");
    m.def(
        "criteria",
        [](const RowRef& meas, const RowRef& pred, py::object n_params, py::object noise_model) {
            const auto p = int_arg(n_params);
            const auto nm = option_arg<dynval::noise_model>(noise_model);
            const information_criteria_result r =
                python_values({{"n_params", n_params}, {"noise_model", noise_model}}, [&] {
                    py::gil_scoped_release release;
                    return dynval::criteria(meas, pred, p, nm);
                });
            py::dict out = criteria_dict(r);
            out["n_obs"] = r.n_obs;
            out["fit_term"] = r.fit_term;
            return out;
        },
        py::arg("meas"), py::arg("pred"), py::arg("n_params"), py::arg("noise_model"),
        "aic, bic, aicc, fpe, naic, n_obs, fit_term of a noise model.");
}

}  // namespace dynval::bindings
