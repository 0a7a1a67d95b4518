// Shared by every binding translation unit: array types and conversions of Python arguments to
// the core's plain parameter types. Bindings only convert; every check lives in the core.
#pragma once

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <dynval/dynval.hpp>

#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace py = pybind11;

namespace dynval::bindings {

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
// C-contiguous float64 arrays bind without a copy; any other dtype or layout (Fortran order,
// strided or reversed views, float32, int) is converted to a C-contiguous float64 copy once.
// A distinct type (not an alias) so that its caster below can normalise strides first.
struct RowRef : Eigen::Ref<const RowMatrix> {
    explicit RowRef(const Eigen::Ref<const RowMatrix>& ref) : Eigen::Ref<const RowMatrix>(ref) {}
};

/// `a` itself, or a copy with canonical strides when a stride is negative. numpy calls an array
/// C-contiguous whatever the stride of a length-1 axis (`tau[:, ::-1]` for one joint), so its
/// own conversion keeps the negative stride, which pybind11's Eigen caster then refuses.
inline py::object canonical_strides(py::handle a) {
    if (!py::isinstance<py::array>(a)) return py::reinterpret_borrow<py::object>(a);
    const auto arr = py::reinterpret_borrow<py::array>(a);
    for (py::ssize_t i = 0; i < arr.ndim(); ++i)
        if (arr.strides(i) < 0) return arr.attr("copy")();
    return arr;
}

void register_errors(py::module_& m);
void register_norms(py::module_& m);
void register_normalized_fit(py::module_& m);
void register_residual_statistics(py::module_& m);
void register_correlation(py::module_& m);
void register_portmanteau(py::module_& m);
void register_information_criteria(py::module_& m);
void register_stream(py::module_& m);
void register_testing(py::module_& m);

inline py::module_ numpy() { return py::module_::import("numpy"); }

/// The facade's text for a value (`dynval.checks._validation.format_value`).
inline std::string value_repr(py::handle value) {
    // The facade's own helper writes the value, so the two messages agree byte for byte, and an
    // array or a long argument is shown by type and shape, never by its values (contract §2.1).
    // Imported per call, not held in a static: errors are rare, and a static object would outlive
    // the interpreter at exit.
    return py::module_::import("dynval.checks._validation").attr("format_value")(value).cast<std::string>();
}

inline bool is_bool(py::handle v) { return PyBool_Check(v.ptr()) || py::isinstance(v, numpy().attr("bool_")); }

inline bool is_integer(py::handle v) {
    if (is_bool(v)) return false;
    return PyLong_Check(v.ptr()) || py::isinstance(v, numpy().attr("integer"));
}

inline bool is_real(py::handle v) {
    if (is_bool(v)) return false;
    return PyLong_Check(v.ptr()) || PyFloat_Check(v.ptr()) || py::isinstance(v, numpy().attr("integer")) ||
           py::isinstance(v, numpy().attr("floating"));
}

// Parameters. The core takes plain C++ values and checks them after the data, in the contract's
// order. An argument that is not even of the right type becomes a value the core refuses (a
// negative integer, NaN, an empty list, an option outside its enum), so the core still reports
// it at its place in that order; `python_values` then writes the caller's own argument into the
// message, as the facade does. Every requirement of an integer parameter excludes negatives.
constexpr long long not_an_integer = -1;

/// An int or numpy integer that fits in 64 bits, else `not_an_integer`.
inline long long int_arg(py::handle v) {
    if (!is_integer(v)) return not_an_integer;
    int overflow = 0;
    py::object as_int = py::reinterpret_steal<py::object>(PyNumber_Index(v.ptr()));
    const long long x = PyLong_AsLongLongAndOverflow(as_int.ptr(), &overflow);
    return overflow != 0 ? not_an_integer : x;
}

/// A real number; NaN when it is not one, inf for an int beyond float64 (10**400).
inline double real_arg(py::handle v) {
    if (!is_real(v)) return std::numeric_limits<double>::quiet_NaN();
    const double x = PyFloat_AsDouble(v.ptr());
    if (x == -1.0 && PyErr_Occurred()) {
        PyErr_Clear();
        return std::numeric_limits<double>::infinity();
    }
    return x;
}

/// True or False (Python or numpy), else nothing: no bool value can stand for "not a bool".
inline std::optional<bool> bool_arg(py::handle v) {
    if (!is_bool(v)) return std::nullopt;
    return py::bool_(py::reinterpret_borrow<py::object>(v)).cast<bool>();
}

/// The option named by a str, else a value outside the enum.
template <class E>
E option_arg(py::handle v) {
    if (py::isinstance<py::str>(v))
        if (const auto value = option_traits<E>::parse(v.cast<std::string>())) return *value;
    return static_cast<E>(-1);
}

/// Integers from an int or a 1-D sequence of ints (lags); anything else is the empty list.
inline std::vector<long long> int_list_arg(py::handle v) {
    const auto one = [](py::handle item, std::vector<long long>& out) {
        // Each integer through int_arg: one beyond 64 bits (2**63, numpy.uint64) is refused as a
        // parameter with the contract's message, not as a pybind11 cast error.
        if (!is_integer(item)) return false;
        const long long x = int_arg(item);
        if (x == not_an_integer) return false;
        out.push_back(x);
        return true;
    };
    std::vector<long long> out;
    if (is_integer(v)) return one(v, out) ? out : std::vector<long long>{};
    if (py::isinstance<py::str>(v) || py::isinstance<py::bytes>(v) ||
        !(py::isinstance<py::sequence>(v) || py::isinstance(v, numpy().attr("ndarray"))))
        return {};
    for (py::handle item : py::reinterpret_borrow<py::iterable>(v))
        if (!one(item, out)) return {};
    return out;
}

/// A Python argument by the name the core gives its parameter.
struct named_arg {
    const char* name;
    py::handle value;
};

/// `call()`, with the value in an InvalidParameter message replaced by the caller's argument
/// written as Python writes it (the core writes C++ values: `2` for 2.0, `-1` for a non-integer).
template <class F>
decltype(auto) python_values(std::initializer_list<named_arg> args, F&& call) {
    try {
        return call();
    } catch (const invalid_parameter& err) {
        for (const auto& a : args)
            if (err.parameter() == a.name) throw invalid_parameter(err.parameter(), err.requirement(), value_repr(a.value));
        throw;
    }
}

/// InvalidParameter for a bool parameter that is not True or False. The core has no refused
/// bool, so the binding raises it itself, after the core has checked everything before it.
[[noreturn]] inline void throw_not_bool(const char* name, py::handle value) {
    throw invalid_parameter(name, "True or False", value_repr(value));
}

/// The kernels' int64 segment starts (None: one segment).
inline segment_spec starts_list(py::handle v) {
    std::vector<long long> out;
    if (v.is_none()) return {};
    auto arr = py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(v);
    if (!arr || arr.ndim() != 1) throw invalid_parameter("segments must be int64 segment starts, got " + value_repr(v));
    for (py::ssize_t i = 0; i < arr.size(); ++i) out.push_back(arr.at(i));
    return segment_spec(std::move(out), true);
}

/// (m,) float64 array or float.
inline py::object metric_to_python(const metric_value& v) {
    if (v.per_joint) return py::cast(Eigen::VectorXd(v.values.matrix()));
    return py::float_(v.value);
}

/// Binds `name(meas, pred, multioutput) -> float or (m,)`: every point metric has this shape.
template <class F>
void def_pair_metric(py::module_& m, const char* name, F f, const char* doc) {
    m.def(
        name,
        [f](const RowRef& meas, const RowRef& pred, py::object multioutput) {
            const auto how = option_arg<dynval::multioutput>(multioutput);
            const metric_value v = python_values({{"multioutput", multioutput}}, [&] {
                py::gil_scoped_release release;
                return f(meas, pred, how);
            });
            return metric_to_python(v);
        },
        py::arg("meas"), py::arg("pred"), py::arg("multioutput"), doc);
}

inline py::array_t<bool> bool_array(const std::vector<bool>& flags) {
    py::array_t<bool> out(static_cast<py::ssize_t>(flags.size()));
    auto w = out.mutable_unchecked<1>();
    for (std::size_t i = 0; i < flags.size(); ++i) w(static_cast<py::ssize_t>(i)) = flags[i];
    return out;
}

inline py::array_t<long long> int_array(const std::vector<long long>& values) {
    py::array_t<long long> out(static_cast<py::ssize_t>(values.size()));
    auto w = out.mutable_unchecked<1>();
    for (std::size_t i = 0; i < values.size(); ++i) w(static_cast<py::ssize_t>(i)) = values[i];
    return out;
}

}  // namespace dynval::bindings

namespace pybind11::detail {

/// RowRef: pybind11's Eigen::Ref caster, applied to the array with canonical strides.
template <>
struct type_caster<dynval::bindings::RowRef> {
    using Base = Eigen::Ref<const dynval::bindings::RowMatrix>;
    static constexpr auto name = type_caster<Base>::name;

    bool load(handle src, bool convert) {
        object normalised = dynval::bindings::canonical_strides(src);
        if (!inner_.load(normalised, convert)) return false;
        value_.emplace(static_cast<Base&>(inner_));
        return true;
    }
    template <typename T>
    using cast_op_type = const dynval::bindings::RowRef&;
    operator const dynval::bindings::RowRef&() const { return *value_; }

private:
    type_caster<Base> inner_;  // keeps the (possibly copied) array alive for the call
    std::optional<dynval::bindings::RowRef> value_;
};

}  // namespace pybind11::detail
