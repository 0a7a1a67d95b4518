// dynval._core._testing: probes used by tests/test_cpp_core.py, not part of the kernel set.
#include "bindings.hpp"

#include <chrono>
#include <string>

namespace dynval::bindings {

namespace {

/// `iterations` steps of 12 independent chains of 4-double multiply-adds (12 · 4 · 2 flops each):
/// enough chains to cover the FMA latency on two pipes. Compiled like the lag kernels (the same
/// x86-64-v3 clone, or -march=native under DYNVAL_NATIVE), so it measures their peak.
DYNVAL_FMA_CLONES double fma_chains(long long iterations, double a, double b) {
#if defined(DYNVAL_VECTOR_TYPES)
    using detail::vec4;
    constexpr int chains = 12;
    vec4 acc[chains];
    for (int k = 0; k < chains; ++k) acc[k] = vec4{} + static_cast<double>(k);
    const vec4 va = vec4{} + a, vb = vec4{} + b;
    for (long long i = 0; i < iterations; ++i)
        for (int k = 0; k < chains; ++k) acc[k] = acc[k] * va + vb;
    double s = 0.0;
    for (int k = 0; k < chains; ++k) s += (acc[k][0] + acc[k][1]) + (acc[k][2] + acc[k][3]);
    return s;
#else
    double acc[48];
    for (int k = 0; k < 48; ++k) acc[k] = k;
    for (long long i = 0; i < iterations; ++i)
        for (int k = 0; k < 48; ++k) acc[k] = acc[k] * a + b;
    double s = 0.0;
    for (double v : acc) s += v;
    return s;
#endif
}

/// The instruction set the cloned kernels run with on this machine.
std::string kernel_isa() {
#if defined(DYNVAL_NO_CLONES)
    return "native build (no clones)";
#elif defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") ? "x86-64-v3 clone (AVX2, FMA)"
                                                                            : "default clone (SSE2)";
#else
    return "no clones (compiler flags)";
#endif
}

}  // namespace

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
    t.def(
        "fma_peak",
        [](long long iterations) {
            double seconds = 0.0, sink = 0.0;
            {
                py::gil_scoped_release release;
                const auto t0 = std::chrono::steady_clock::now();
                sink = fma_chains(iterations, 1.0 - 1e-9, 1e-9);
                seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            }
            return py::make_tuple(2.0 * 48.0 * static_cast<double>(iterations), seconds, sink, kernel_isa());
        },
        py::arg("iterations"),
        "(flops, seconds, checksum, isa): `iterations` steps of 12 independent 4-wide multiply-add chains, "
        "compiled like the lag kernels (the benchmarks' FMA peak per core).");
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
