// dynval._core._testing: probes used by tests/test_cpp_core.py, not part of the kernel set.
#include "bindings.hpp"

namespace dynval::bindings {

void register_testing(py::module_& m) {
    auto t = m.def_submodule("_testing", "Probes for the test suite (not a public API).");
    t.def(
        "data_address", [](const RowRef& a) { return reinterpret_cast<std::uintptr_t>(a.data()); }, py::arg("a"),
        "Address of the data the kernels see (equal to the array's own address when no copy is made).");
    t.def("chi2_sf", py::vectorize(&dynval::chi2_sf), py::arg("q"), py::arg("df"));
    t.def("chi2_logsf", py::vectorize(&dynval::chi2_logsf), py::arg("q"), py::arg("df"));
    t.def("normal_quantile", py::vectorize(&dynval::normal_quantile), py::arg("p"));
    t.def(
        "confidence_band",
        [](py::object n, py::object level) { return dynval::confidence_band(int_param(n), real_param(level)); },
        py::arg("n"), py::arg("level"));
}

}  // namespace dynval::bindings
