// Family `portmanteau`: Ljung–Box and Box–Pierce with p-values and log p-values.
#include "bindings.hpp"

namespace dynval::bindings {

void register_portmanteau(py::module_& m) {
    m.def(
        "portmanteau",
        [](const RowRef& e, py::object lags, py::object model_df, py::object starts, py::object test) {
            const auto h = int_list_arg(lags);
            const auto mdf = int_arg(model_df);
            const auto seg = starts_list(starts);
            const auto which = option_arg<portmanteau_test>(test);
            const PortmanteauTest r =
                python_values({{"lags", lags}, {"model_df", model_df}, {"test", test}}, [&] {
                    py::gil_scoped_release release;
                    return dynval::portmanteau(e, h, mdf, seg, which);
                });
            py::dict out;
            out["statistic"] = py::cast(Eigen::MatrixXd(r.statistic.matrix()));
            out["pvalue"] = py::cast(Eigen::MatrixXd(r.pvalue.matrix()));
            out["log_pvalue"] = py::cast(Eigen::MatrixXd(r.log_pvalue.matrix()));
            out["df"] = int_array(r.df);
            return out;
        },
        py::arg("e"), py::arg("lags"), py::arg("model_df"), py::arg("starts"), py::arg("test"),
        "statistic, pvalue, log_pvalue (n_lags, m) and df (n_lags,) of test 'ljung_box' or 'box_pierce'.");
}

}  // namespace dynval::bindings
