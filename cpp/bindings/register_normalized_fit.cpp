// Family `normalized_fit`: vaf, fit_percent, r2.
#include "bindings.hpp"

namespace dynval::bindings {

void register_normalized_fit(py::module_& m) {
    def_pair_metric(
        m, "vaf", [](const RowRef& a, const RowRef& b, multioutput h) { return dynval::vaf(a, b, h); },
        "Variance accounted for, percent: float or (m,).");
    def_pair_metric(
        m, "fit_percent",
        [](const RowRef& a, const RowRef& b, multioutput h) { return dynval::fit_percent(a, b, h); },
        "NRMSE fit, percent: float or (m,).");
    def_pair_metric(
        m, "r2", [](const RowRef& a, const RowRef& b, multioutput h) { return dynval::r2(a, b, h); },
        "Coefficient of determination: float or (m,).");
}

}  // namespace dynval::bindings
