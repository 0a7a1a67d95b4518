// Error translation and the finiteness kernel.
//
// dynval::input_error reaches Python as the facade's own class for its kind
// (dynval.checks._errors.error_class(kind)), so callers catch dynval.InputError subclasses whichever
// backend ran; no new exception types are created here.
#include "bindings.hpp"

namespace dynval::bindings {

void register_errors(py::module_& m) {
    py::register_exception_translator([](std::exception_ptr ptr) {
        if (!ptr) return;
        try {
            std::rethrow_exception(ptr);
        } catch (const dynval::input_error& err) {
            py::object cls;
            try {
                cls = py::module_::import("dynval.checks._errors").attr("error_class")(dynval::kind_name(err.kind()));
            } catch (py::error_already_set&) {
                // Only reachable when _core is imported without its package; keep the base type.
                cls = py::reinterpret_borrow<py::object>(PyExc_ValueError);
            }
            py::object instance = cls(err.what());
            PyErr_SetObject(cls.ptr(), instance.ptr());
        }
    });

    m.def(
        "first_nonfinite",
        [](const RowRef& a) -> py::object {
            std::optional<nonfinite_entry> hit;
            {
                py::gil_scoped_release release;
                hit = dynval::first_nonfinite(a);
            }
            if (!hit) return py::none();
            return py::make_tuple(static_cast<long long>(hit->row), static_cast<long long>(hit->col), hit->value);
        },
        py::arg("a"), "(row, col, value) of the first NaN or ±inf in row-major order, or None.");
}

}  // namespace dynval::bindings
