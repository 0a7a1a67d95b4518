// Family `stream`: dynval::stream_state, the mergeable state behind
// dynval.stream.ValidationAccumulator(backend="cpp") (contract §4.1). Bindings only convert.
#include "bindings.hpp"

#include <array>

namespace dynval::bindings {

namespace {

py::array_t<double> to_array(const std::vector<double>& v, std::vector<py::ssize_t> shape) {
    py::array_t<double> out(shape);
    std::copy(v.begin(), v.end(), out.mutable_data());
    return out;
}

std::vector<double> from_array(py::handle a) {
    auto arr = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
    if (!arr) throw invalid_parameter("StreamState: a saved array is not float64");
    return std::vector<double>(arr.data(), arr.data() + arr.size());
}

// f(&y as rows) or f(nullptr) for None, without the GIL; anything else is InvalidParameter.
template <class F>
void with_optional_rows(py::handle y, F&& f) {
    if (y.is_none()) {
        py::gil_scoped_release release;
        f(static_cast<const RowRef*>(nullptr));
        return;
    }
    auto cast = py::detail::make_caster<RowRef>();
    if (!cast.load(y, true)) throw invalid_parameter("y must be a float64 matrix or None");
    const RowRef& rows = cast;
    py::gil_scoped_release release;
    f(&rows);
}

// Every compensated sum and plain vector of the state, in one fixed order (pickling).
template <class S, class F>
void each_field(S& st, F&& f) {
    for (auto* c : {&st.prod_e, &st.cur_e, &st.lag_e, &st.gram, &st.sum_t, &st.sq_t, &st.sq_y, &st.lag_y, &st.prod_ey}) {
        f(c->hi);
        f(c->lo);
    }
    for (auto* v : {&st.k_e, &st.min_e, &st.max_e, &st.k_t, &st.min_t, &st.max_t, &st.k_y, &st.min_y, &st.max_y,
                    &st.head_e, &st.tail_e, &st.tail_y})
        f(*v);
}

}  // namespace

void register_stream(py::module_& m) {
    py::class_<stream_state>(m, "StreamState",
                             "Mergeable centred sums of a validation stream (contract §4.1); the C++ form of "
                             "dynval.streaming._stream.State.")
        .def(py::init([](py::object n_joints, py::object n_columns, py::object acf_lags, py::object xcorr_lags,
                         py::object gram) {
                 const auto count = [](py::handle v, const char* name, long long lo, const char* requirement) {
                     const long long x = int_arg(v);
                     if (x < lo) throw invalid_parameter(name, requirement, value_repr(v));
                     return x;
                 };
                 stream_layout l;
                 l.m = count(n_joints, "n_joints", 1, "a positive integer");
                 l.p = count(n_columns, "n_columns", 0, "an integer with n_columns >= 0");
                 l.acf_lags = count(acf_lags, "acf_lags", 0, "an integer with acf_lags >= 0");
                 l.xcorr_lags = count(xcorr_lags, "xcorr_lags", 0, "an integer with xcorr_lags >= 0");
                 const auto g = bool_arg(gram);
                 if (!g) throw_not_bool("gram", gram);
                 l.gram = *g;
                 return stream_state(l);
             }),
             py::arg("n_joints"), py::arg("n_columns"), py::arg("acf_lags"), py::arg("xcorr_lags"), py::arg("gram"))
        .def(
            "append",
            [](stream_state& st, const RowRef& e, const RowRef& tau, py::object y) {
                with_optional_rows(y, [&](const RowRef* yr) {
                    if (yr)
                        st.append(e, tau, *yr);
                    else
                        st.append(e, tau);
                });
            },
            py::arg("e"), py::arg("tau"), py::arg("y"),
            "Adds rows continuing the current segment: e, tau (c, m), y (c, m*p) or None.")
        .def(
            "append_measured",
            [](stream_state& st, const RowRef& meas, const RowRef& pred, py::object y) {
                with_optional_rows(y, [&](const RowRef* yr) { st.append_measured(meas, pred, yr ? *yr : meas, yr != nullptr); });
            },
            py::arg("meas"), py::arg("pred"), py::arg("y"),
            "append of the residual meas - pred, formed block by block: meas, pred (c, m), y (c, m*p) or None.")
        .def(
            "merge",
            [](stream_state& st, const stream_state& later) {
                py::gil_scoped_release release;
                st.merge(later);
            },
            py::arg("later"), "Adds the rows of `later`, which follow this state's rows in time.")
        .def("copy", [](const stream_state& st) { return stream_state(st); }, "An independent copy.")
        .def_property_readonly("n", [](const stream_state& st) { return st.n; })
        .def_property_readonly("lengths", [](const stream_state& st) { return st.lengths; })
        .def_readwrite("start_break", &stream_state::start_break)
        .def_readwrite("end_break", &stream_state::end_break)
        .def(
            "sums",
            [](const stream_state& st) {
                const auto& l = st.layout();
                const py::ssize_t m = l.m, p = l.p, le = l.acf_lags + 1, lx = l.xcorr_lags + 1;
                py::dict d;
                d["k_e"] = to_array(st.k_e, {m});
                d["prod_e"] = to_array(st.prod_e.values(), {le, m});
                d["cur_e"] = to_array(st.cur_e.values(), {le, m});
                d["lag_e"] = to_array(st.lag_e.values(), {le, m});
                d["pairs"] = int_array(st.pairs);
                d["gram"] = l.gram ? py::object(to_array(st.gram.values(), {m, m})) : py::none();
                d["min_e"] = to_array(st.min_e, {m});
                d["max_e"] = to_array(st.max_e, {m});
                d["k_t"] = to_array(st.k_t, {m});
                d["sum_t"] = to_array(st.sum_t.values(), {m});
                d["sq_t"] = to_array(st.sq_t.values(), {m});
                d["min_t"] = to_array(st.min_t, {m});
                d["max_t"] = to_array(st.max_t, {m});
                d["k_y"] = to_array(st.k_y, {m, p});
                d["sq_y"] = to_array(st.sq_y.values(), {m, p});
                d["lag_y"] = to_array(st.lag_y.values(), {lx, m, p});
                d["prod_ey"] = to_array(st.prod_ey.values(), {lx, m, p});
                d["min_y"] = to_array(st.min_y, {m, p});
                d["max_y"] = to_array(st.max_y, {m, p});
                return d;
            },
            "The sums (compensated ones as hi + lo) as arrays named as in dynval.streaming._stream.State.")
        .def(py::pickle(
            [](const stream_state& st) {
                const auto& l = st.layout();
                py::list arrays;
                each_field(st, [&](const std::vector<double>& v) {
                    arrays.append(to_array(v, {static_cast<py::ssize_t>(v.size())}));
                });
                return py::make_tuple(py::make_tuple(l.m, l.p, l.acf_lags, l.xcorr_lags, l.gram), st.n, st.lengths,
                                      st.start_break, st.end_break, int_array(st.pairs), arrays);
            },
            [](py::tuple t) {
                const auto lt = t[0].cast<py::tuple>();
                stream_layout l;
                l.m = lt[0].cast<Index>();
                l.p = lt[1].cast<Index>();
                l.acf_lags = lt[2].cast<Index>();
                l.xcorr_lags = lt[3].cast<Index>();
                l.gram = lt[4].cast<bool>();
                stream_state st(l);
                st.n = t[1].cast<long long>();
                st.lengths = t[2].cast<std::vector<long long>>();
                st.start_break = t[3].cast<bool>();
                st.end_break = t[4].cast<bool>();
                st.pairs = t[5].cast<std::vector<long long>>();
                const auto arrays = t[6].cast<py::list>();
                std::size_t i = 0;
                each_field(st, [&](std::vector<double>& v) { v = from_array(arrays[i++]); });
                return st;
            }));
}

}  // namespace dynval::bindings
