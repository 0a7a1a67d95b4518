// Family `norms`: residuals, sse, rmse, max_abs_error.
#include "bindings.hpp"

namespace dynval::bindings {

void register_norms(py::module_& m) {
    m.def(
        "residuals",
        [](const RowRef& meas, const RowRef& pred) {
            py::gil_scoped_release release;
            return RowMatrix(dynval::residuals(meas, pred));
        },
        py::arg("meas"), py::arg("pred"), "e = meas - pred, shape (N, m).");
    def_pair_metric(
        m, "sse", [](const RowRef& a, const RowRef& b, multioutput h) { return dynval::sse(a, b, h); },
        "Sum of squared errors: float or (m,).");
    def_pair_metric(
        m, "max_abs_error", [](const RowRef& a, const RowRef& b, multioutput h) { return dynval::max_abs_error(a, b, h); },
        "Maximum absolute error: float or (m,).");
    m.def(
        "rmse",
        [](const RowRef& meas, const RowRef& pred, py::object multioutput, py::object convention) {
            const auto how = option_arg<dynval::multioutput>(multioutput);
            std::optional<rmse_convention> conv;
            const bool unset = convention.is_none() ||
                               (py::isinstance<py::str>(convention) && convention.cast<std::string>().empty());
            if (!unset) conv = option_arg<rmse_convention>(convention);
            const metric_value v = python_values({{"multioutput", multioutput}, {"convention", convention}}, [&] {
                py::gil_scoped_release release;
                return dynval::rmse(meas, pred, how, conv);
            });
            return metric_to_python(v);
        },
        py::arg("meas"), py::arg("pred"), py::arg("multioutput"), py::arg("convention"),
        "RMSE: float or (m,); convention '' (or None) is the default per_element.");
}

}  // namespace dynval::bindings
