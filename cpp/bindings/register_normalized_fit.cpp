// Family `normalized_fit`: vaf, fit_percent, r2.
#include "bindings.hpp"

namespace dynval::bindings {

namespace {
template <class F>
void def_normalized(py::module_& m, const char* name, F f, const char* doc) {
    m.def(
        name,
        [f](const RowRef& meas, const RowRef& pred, py::object multioutput) {
            const auto how = option_param<dynval::multioutput>(multioutput);
            metric_value v;
            {
                py::gil_scoped_release release;
                v = f(meas, pred, how);
            }
            return metric_to_python(v);
        },
        py::arg("meas"), py::arg("pred"), py::arg("multioutput"), doc);
}
}  // namespace

void register_normalized_fit(py::module_& m) {
    def_normalized(
        m, "vaf", [](const RowRef& a, const RowRef& b, const param<multioutput>& h) { return dynval::vaf(a, b, h); },
        "Variance accounted for, percent: float or (m,).");
    def_normalized(
        m, "fit_percent",
        [](const RowRef& a, const RowRef& b, const param<multioutput>& h) { return dynval::fit_percent(a, b, h); },
        "NRMSE fit, percent: float or (m,).");
    def_normalized(
        m, "r2", [](const RowRef& a, const RowRef& b, const param<multioutput>& h) { return dynval::r2(a, b, h); },
        "Coefficient of determination: float or (m,).");
}

}  // namespace dynval::bindings
