// Families `autocorrelation` and `cross_correlation`.
#include "bindings.hpp"

namespace dynval::bindings {

void register_correlation(py::module_& m) {
    m.def(
        "autocorrelation",
        [](const RowRef& e, py::object max_lag, py::object adjusted, py::object starts) {
            const auto lag = int_arg(max_lag);
            const auto adj = bool_arg(adjusted);
            const auto seg = starts_list(starts);
            row_matrix rho = python_values({{"max_lag", max_lag}}, [&] {
                py::gil_scoped_release release;
                return dynval::autocorrelation(e, lag, adj.value_or(true), seg);
            });
            if (!adj) throw_not_bool("adjusted", adjusted);  // checked last: after the core's checks
            return rho;
        },
        py::arg("e"), py::arg("max_lag"), py::arg("adjusted"), py::arg("starts"),
        "ρ̂(ℓ) for ℓ = 0..max_lag per joint, (max_lag+1, m).");
    py::class_<joint_moments>(m, "RegressorMoments",
                              "A regressor's column moments, kept for later cross_correlation calls.")
        .def_readonly("n_samples", &joint_moments::n_samples)
        .def_readonly("n_columns", &joint_moments::n_joints)
        // Each column's smallest and largest value (exact): the report's columns' largest |x| from
        // the same pass, instead of two more over the regressor.
        .def_property_readonly("column_min", [](const joint_moments& mo) { return Eigen::VectorXd(mo.tau_min); })
        .def_property_readonly("column_max", [](const joint_moments& mo) { return Eigen::VectorXd(mo.tau_max); });
    m.def(
        "regressor_moments",
        [](const RowRef& y) {
            py::gil_scoped_release release;
            return dynval::regressor_moments(y);
        },
        py::arg("Y"), "The moments of Y's columns that cross_correlation computes first (its moments= argument).");
    m.def(
        "cross_correlation",
        [](const RowRef& e, const RowRef& y, py::object n_columns, py::object max_lag, py::object adjusted,
           py::object starts, const joint_moments* moments) {
            const auto p = int_arg(n_columns);
            const auto lag = int_arg(max_lag);
            const auto adj = bool_arg(adjusted);
            const auto seg = starts_list(starts);
            const CrossCorrelation r = python_values({{"n_columns", n_columns}, {"max_lag", max_lag}}, [&] {
                py::gil_scoped_release release;
                return dynval::cross_correlation(e, y, p, lag, adj.value_or(true), seg, moments);
            });
            if (!adj) throw_not_bool("adjusted", adjusted);  // checked last: after the core's checks
            py::dict out;
            out["rho"] = py::cast(r.rho);
            out["constant_mask"] = bool_array(r.constant_mask);
            return out;
        },
        py::arg("e"), py::arg("Y"), py::arg("n_columns"), py::arg("max_lag"), py::arg("adjusted"), py::arg("starts"),
        py::arg("moments") = nullptr,
        "rho (m·p, max_lag+1), row j·p + c, and constant_mask (m·p,); moments: regressor_moments(Y), kept.");
}

}  // namespace dynval::bindings
