// Family `stream`: dynval::stream_state, the mergeable state behind
// dynval.stream.ValidationAccumulator(backend="cpp") (contract §4.1). Bindings only convert.
#include "bindings.hpp"

#include <array>
#include <limits>
#include <string>
#include <utility>

namespace dynval::bindings {

namespace {

py::array_t<double> to_array(const std::vector<double>& v, std::vector<py::ssize_t> shape) {
    py::array_t<double> out(shape);
    std::copy(v.begin(), v.end(), out.mutable_data());
    return out;
}

// __setstate__'s refusal: the saved state does not match its layout (a pickle from elsewhere).
[[noreturn]] void bad_state(const std::string& field, const std::string& expected, const std::string& got) {
    throw invalid_parameter("StreamState.__setstate__: " + field + " must be " + expected + ", got " + got);
}

std::vector<double> from_array(py::handle a, const char* field) {
    auto arr = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
    if (!arr) bad_state(field, "a float64 array", std::string(py::str(py::type::of(a).attr("__name__"))));
    return std::vector<double>(arr.data(), arr.data() + arr.size());
}

std::string values_text(std::size_t count) { return std::to_string(count) + " values"; }

// A saved integer field: `lo <= x <= hi`, else the refusal naming it.
long long saved_int(py::handle v, const char* field, long long lo, long long hi) {
    const long long x = int_arg(v);
    if (!is_integer(v) || x < lo || x > hi)
        bad_state(field, "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]",
                  std::string(py::repr(v)));
    return x;
}

std::vector<long long> saved_ints(py::handle v, const char* field, std::size_t size, long long lo, long long hi) {
    auto arr = py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(v);
    if (!arr) bad_state(field, "an integer array", std::string(py::str(py::type::of(v).attr("__name__"))));
    if (static_cast<std::size_t>(arr.size()) != size) bad_state(field, values_text(size), values_text(arr.size()));
    std::vector<long long> out(arr.data(), arr.data() + arr.size());
    for (const long long x : out)
        if (x < lo || x > hi)
            bad_state(field, "integers in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]", std::to_string(x));
    return out;
}

bool saved_bool(py::handle v, const char* field) {
    const auto b = bool_arg(v);
    if (!b) bad_state(field, "a bool", std::string(py::repr(v)));
    return *b;
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

// Every compensated sum and plain vector of the state with its name, in one fixed order (pickling).
template <class S, class F>
void each_field(S& st, F&& f) {
    const std::array<std::pair<decltype(&st.prod_e), const char*>, 9> sums{{{&st.prod_e, "prod_e"},
                                                                             {&st.cur_e, "cur_e"},
                                                                             {&st.lag_e, "lag_e"},
                                                                             {&st.gram, "gram"},
                                                                             {&st.sum_t, "sum_t"},
                                                                             {&st.sq_t, "sq_t"},
                                                                             {&st.sq_y, "sq_y"},
                                                                             {&st.lag_y, "lag_y"},
                                                                             {&st.prod_ey, "prod_ey"}}};
    for (const auto& [c, name] : sums) {
        f(c->hi, (std::string(name) + ".hi").c_str());
        f(c->lo, (std::string(name) + ".lo").c_str());
    }
    const std::array<std::pair<decltype(&st.k_e), const char*>, 12> rows{{{&st.k_e, "k_e"},
                                                                           {&st.min_e, "min_e"},
                                                                           {&st.max_e, "max_e"},
                                                                           {&st.k_t, "k_t"},
                                                                           {&st.min_t, "min_t"},
                                                                           {&st.max_t, "max_t"},
                                                                           {&st.k_y, "k_y"},
                                                                           {&st.min_y, "min_y"},
                                                                           {&st.max_y, "max_y"},
                                                                           {&st.head_e, "head_e"},
                                                                           {&st.tail_e, "tail_e"},
                                                                           {&st.tail_y, "tail_y"}}};
    for (const auto& [v, name] : rows) f(*v, name);
}

constexpr std::size_t saved_arrays = 30;  // each_field's count
constexpr long long largest_exponent = 1024, smallest_exponent = -1073;  // std::frexp's range for finite doubles

// The state a pickle describes, every size and count checked against its layout before any is
// used: the loops of sums(), merge() and append() index the arrays by the layout's sizes.
stream_state restored(const py::tuple& t) {
    if (t.size() != 8) bad_state("the state", "a tuple of 8 items", std::to_string(t.size()) + " items");
    if (!py::isinstance<py::tuple>(t[0]) || py::len(t[0]) != 5)
        bad_state("layout", "a tuple (m, p, acf_lags, xcorr_lags, gram)", std::string(py::repr(t[0])));
    const auto lt = t[0].cast<py::tuple>();
    stream_layout l;
    constexpr long long any = std::numeric_limits<long long>::max();
    l.m = saved_int(lt[0], "layout m", 1, any);
    l.p = saved_int(lt[1], "layout p", 0, any);
    l.acf_lags = saved_int(lt[2], "layout acf_lags", 0, any);
    l.xcorr_lags = saved_int(lt[3], "layout xcorr_lags", 0, l.acf_lags);
    l.gram = saved_bool(lt[4], "layout gram");
    stream_state st(l);  // refuses a layout that does not fit, before anything else is allocated
    st.n = saved_int(t[1], "n", 0, any);
    if (!py::isinstance<py::sequence>(t[2])) bad_state("lengths", "a list of ints", std::string(py::repr(t[2])));
    long long total = 0;
    for (py::handle v : t[2].cast<py::sequence>()) {
        const long long len = saved_int(v, "a segment length", 1, st.n - total);
        total += len;
        st.lengths.push_back(len);
    }
    if (total != st.n) bad_state("lengths", "segment lengths summing to n=" + std::to_string(st.n), "a sum of " + std::to_string(total));
    st.start_break = saved_bool(t[3], "start_break");
    st.end_break = saved_bool(t[4], "end_break");
    st.pairs = saved_ints(t[5], "pairs", st.pairs.size(), 0, st.n);
    const auto arrays = t[6].cast<py::list>();
    if (arrays.size() != saved_arrays)
        bad_state("the arrays", "a list of " + std::to_string(saved_arrays), std::to_string(arrays.size()) + " arrays");
    const auto m = static_cast<std::size_t>(l.m), mp = m * static_cast<std::size_t>(l.p);
    const auto rows_held = [&](Index lags) { return static_cast<std::size_t>(std::min<long long>(lags, st.n)); };
    std::size_t i = 0;
    each_field(st, [&](std::vector<double>& v, const char* name) {
        auto saved = from_array(arrays[i++], name);
        const std::string field(name);
        // the boundary rows: up to acf_lags (xcorr_lags for Y) whole rows; every other array has its layout's size
        const std::size_t width = field == "tail_y" ? mp : m;
        const std::size_t most = field == "tail_y" ? rows_held(l.xcorr_lags) : rows_held(l.acf_lags);
        if (field == "head_e" || field == "tail_e" || field == "tail_y") {
            if ((width == 0 ? !saved.empty() : saved.size() % width != 0) || (width && saved.size() / width > most))
                bad_state(name, "whole rows of " + std::to_string(width) + " values, at most " + std::to_string(most) +
                                    " rows (" + values_text(most * width) + ")",
                          values_text(saved.size()));
        } else if (saved.size() != v.size()) {
            bad_state(name, values_text(v.size()), values_text(saved.size()));
        }
        v = std::move(saved);
    });
    const auto exps = t[7].cast<py::tuple>();
    if (exps.size() != 3) bad_state("the exponents", "a tuple (exp_e, exp_t, exp_y)", std::to_string(exps.size()) + " items");
    st.exp_e = saved_ints(exps[0], "exp_e", m, smallest_exponent, largest_exponent);
    st.exp_t = saved_ints(exps[1], "exp_t", m, smallest_exponent, largest_exponent);
    st.exp_y = saved_ints(exps[2], "exp_y", mp, smallest_exponent, largest_exponent);
    return st;
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
                d["exp_e"] = int_array(st.exp_e);
                d["exp_t"] = int_array(st.exp_t);
                d["exp_y"] = int_array(st.exp_y).reshape(std::vector<py::ssize_t>{m, p});
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
                // the boundary rows (raw): the bias test corrects its prewhitened sums at the stream's two ends
                d["head_e"] = to_array(st.head_e, {static_cast<py::ssize_t>(st.head_e.size()) / m, m});
                d["tail_e"] = to_array(st.tail_e, {static_cast<py::ssize_t>(st.tail_e.size()) / m, m});
                return d;
            },
            "The sums (compensated ones as hi + lo) and the boundary rows head_e, tail_e as arrays named as in "
            "dynval.streaming._stream.State.")
        .def(py::pickle(
            [](const stream_state& st) {
                const auto& l = st.layout();
                py::list arrays;
                each_field(st, [&](const std::vector<double>& v, const char*) {
                    arrays.append(to_array(v, {static_cast<py::ssize_t>(v.size())}));
                });
                return py::make_tuple(py::make_tuple(l.m, l.p, l.acf_lags, l.xcorr_lags, l.gram), st.n, st.lengths,
                                      st.start_break, st.end_break, int_array(st.pairs), arrays,
                                      py::make_tuple(int_array(st.exp_e), int_array(st.exp_t), int_array(st.exp_y)));
            },
            [](py::tuple t) { return restored(t); }));
}

}  // namespace dynval::bindings
