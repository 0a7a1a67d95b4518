// Families `autocorrelation` and `cross_correlation`.
#include "bindings.hpp"

namespace dynval::bindings {

void register_correlation(py::module_& m) {
    m.def(
        "autocorrelation",
        [](const RowRef& e, py::object max_lag, py::object adjusted, py::object starts) {
            const auto lag = int_param(max_lag);
            const auto adj = bool_param(adjusted);
            const auto seg = starts_list(starts);
            py::gil_scoped_release release;
            return dynval::autocorrelation(e, lag, adj, seg);
        },
        py::arg("e"), py::arg("max_lag"), py::arg("adjusted"), py::arg("starts"),
        "ρ̂(ℓ) for ℓ = 0..max_lag per joint, (max_lag+1, m).");
    m.def(
        "cross_correlation",
        [](const RowRef& e, const RowRef& y, py::object n_columns, py::object max_lag, py::object adjusted,
           py::object starts) {
            const auto p = int_param(n_columns);
            const auto lag = int_param(max_lag);
            const auto adj = bool_param(adjusted);
            const auto seg = starts_list(starts);
            CrossCorrelation r;
            {
                py::gil_scoped_release release;
                r = dynval::cross_correlation(e, y, p, lag, adj, seg);
            }
            py::dict out;
            out["rho"] = py::cast(r.rho);
            out["constant_mask"] = bool_array(r.constant_mask);
            return out;
        },
        py::arg("e"), py::arg("Y"), py::arg("n_columns"), py::arg("max_lag"), py::arg("adjusted"), py::arg("starts"),
        "rho (m·p, max_lag+1), row j·p + c, and constant_mask (m·p,).");
}

}  // namespace dynval::bindings
