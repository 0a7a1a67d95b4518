// dynval._core: the compiled backend. It exposes exactly the kernels of docs/contract.md §5.1,
// with the signatures and return values of dynval.kernels._reference, so the facade can call either.
#include "bindings.hpp"

PYBIND11_MODULE(_core, m) {
    m.doc() = "dynval compiled backend: C++17/Eigen kernels of the dynval contract (docs/contract.md §5.1).";
    m.attr("__version__") = DYNVAL_VERSION_STRING;
    m.attr("CONTRACT_VERSION") = DYNVAL_CONTRACT_VERSION;
    m.attr("EIGEN_VERSION") = std::to_string(EIGEN_WORLD_VERSION) + "." + std::to_string(EIGEN_MAJOR_VERSION) + "." +
                              std::to_string(EIGEN_MINOR_VERSION);
    dynval::bindings::register_errors(m);
    dynval::bindings::register_norms(m);
    dynval::bindings::register_normalized_fit(m);
    dynval::bindings::register_residual_statistics(m);
    dynval::bindings::register_correlation(m);
    dynval::bindings::register_portmanteau(m);
    dynval::bindings::register_information_criteria(m);
    dynval::bindings::register_stream(m);
    dynval::bindings::register_testing(m);
}
