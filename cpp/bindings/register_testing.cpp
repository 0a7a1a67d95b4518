// dynval._core._testing: probes used by tests/test_cpp_core.py, not part of the kernel set.
#include "bindings.hpp"

namespace dynval::bindings {

void register_testing(py::module_& m) {
    auto t = m.def_submodule("_testing", "Probes for the test suite (not a public API).");
    t.def(
        "data_address", [](const RowRef& a) { return reinterpret_cast<std::uintptr_t>(a.data()); }, py::arg("a"),
        "Address of the data the kernels see (equal to the array's own address when no copy is made).");
    t.def(
        "read_sum",
        [](py::array_t<double, py::array::c_style> a) {
            // A compiled tight read loop: every element read once (the benchmarks' "read once" row).
            const double* x = a.data();
            const py::ssize_t n = a.size();
            double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
            {
                py::gil_scoped_release release;
                py::ssize_t i = 0;
                for (; i + 4 <= n; i += 4) {
                    s0 += x[i];
                    s1 += x[i + 1];
                    s2 += x[i + 2];
                    s3 += x[i + 3];
                }
                for (; i < n; ++i) s0 += x[i];
            }
            return (s0 + s1) + (s2 + s3);
        },
        py::arg("a"), "Sum of a C-contiguous float64 array, reading every element once (a speed reference).");
    t.def("chi2_sf", py::vectorize(&dynval::chi2_sf), py::arg("q"), py::arg("df"));
    t.def("chi2_logsf", py::vectorize(&dynval::chi2_logsf), py::arg("q"), py::arg("df"));
    t.def("normal_quantile", py::vectorize(&dynval::normal_quantile), py::arg("p"));
    t.def(
        "confidence_band",
        [](py::object n, py::object level) {
            return python_values({{"n", n}, {"level", level}},
                                 [&] { return dynval::confidence_band(int_arg(n), real_arg(level)); });
        },
        py::arg("n"), py::arg("level"));
}

}  // namespace dynval::bindings
