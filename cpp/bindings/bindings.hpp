// Shared by every binding translation unit: array types and conversions of Python arguments to
// the core's parameter types. Bindings only convert; every check lives in the core.
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

/// The facade's text for a value: numpy scalars and arrays shown as Python ones, then repr.
inline std::string value_repr(py::handle value) {
    py::object v = py::reinterpret_borrow<py::object>(value);
    const auto np = numpy();
    if (py::isinstance(v, np.attr("ndarray"))) {
        v = v.attr("tolist")();
    } else if (py::isinstance(v, np.attr("generic"))) {
        v = v.attr("item")();
    }
    return py::repr(v).cast<std::string>();
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

inline param<long long> int_param(py::handle v) {
    if (!is_integer(v)) return param<long long>::invalid(value_repr(v));
    int overflow = 0;
    py::object as_int = py::reinterpret_steal<py::object>(PyNumber_Index(v.ptr()));
    const long long x = PyLong_AsLongLongAndOverflow(as_int.ptr(), &overflow);
    if (overflow != 0) return param<long long>::invalid(value_repr(v));
    auto p = param<long long>(x);
    return p;
}

inline param<double> real_param(py::handle v) {
    if (!is_real(v)) return param<double>::invalid(value_repr(v));
    const double x = PyFloat_AsDouble(v.ptr());
    if (x == -1.0 && PyErr_Occurred()) {  // an int beyond float64 (10**400): not a finite number
        PyErr_Clear();
        return param<double>(std::numeric_limits<double>::infinity(), value_repr(v));
    }
    return param<double>(x);
}

inline param<bool> bool_param(py::handle v) {
    if (!is_bool(v)) return param<bool>::invalid(value_repr(v));
    return param<bool>(py::bool_(py::reinterpret_borrow<py::object>(v)).cast<bool>());
}

template <class E>
param<E> option_param(py::handle v) {
    if (!py::isinstance<py::str>(v)) return param<E>::invalid(value_repr(v));
    return param<E>(v.cast<std::string>());
}

/// Integers from an int or a 1-D sequence of ints (lags); anything else stays invalid.
inline param<std::vector<long long>> int_list_param(py::handle v) {
    using P = param<std::vector<long long>>;
    std::vector<long long> out;
    // Each integer through int_param: one beyond 64 bits (2**63, numpy.uint64) is then an invalid
    // parameter with the contract's message, not a pybind11 cast error.
    if (is_integer(v)) {
        const auto one = int_param(v);
        if (!one.valid()) return P::invalid(value_repr(v));
        out.push_back(one.value());
        return P(std::move(out), value_repr(v));
    }
    if (py::isinstance<py::str>(v) || py::isinstance<py::bytes>(v) || !py::isinstance<py::sequence>(v)) {
        if (!py::isinstance(v, numpy().attr("ndarray"))) return P::invalid(value_repr(v));
    }
    for (py::handle item : py::reinterpret_borrow<py::iterable>(v)) {
        const auto one = int_param(item);
        if (!one.valid()) return P::invalid(value_repr(v));
        out.push_back(one.value());
    }
    return P(std::move(out), value_repr(v));
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
