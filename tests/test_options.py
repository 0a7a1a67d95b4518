"""``validate``'s keywords are declared once (``report/_options.py``, ``OPTIONS``).

What reads the declarations is held to them here: ``validate``'s explicit signature (its names and
defaults), the accumulator's signature and refusals, the command line's flags, the order of the
checks and the contract's table (§4).
"""

from __future__ import annotations

import inspect
import math
import re
from pathlib import Path

import numpy as np
import pytest

import dynval
from dynval.checks._errors import InvalidParameter
from dynval.cli import build_parser, main
from dynval.report import _options
from dynval.report._options import NAMES, OPTIONS, REQUIRED, UNSUPPORTED, Flag, Keywords, Option, check_options
from dynval.stream import ValidationAccumulator

ROOT = Path(__file__).resolve().parents[1]

# validate's keywords that are not settings: its data and the model's own parameters (contract §8)
NOT_SETTINGS = {"tau_meas", "tau_pred", "regressor", "parameters"}


def _keywords(function) -> dict[str, object]:
    return {name: p.default for name, p in inspect.signature(function).parameters.items()
            if name not in NOT_SETTINGS and name != "self"}


def test_validate_signature_is_the_declarations():
    signature = _keywords(dynval.validate)
    assert list(signature) != [], "validate has no keywords"
    assert set(signature) == set(NAMES)
    for o in OPTIONS:
        want = inspect.Parameter.empty if o.default is REQUIRED else o.default
        assert signature[o.name] == want, f"validate's default of {o.name} is not its declaration's"


def test_the_accumulator_signature_is_the_declarations():
    signature = _keywords(ValidationAccumulator.__init__)
    supported = {o.name for o in OPTIONS if o.stream == "supported"}
    assert set(signature) == supported | set(UNSUPPORTED)
    for o in OPTIONS:
        if o.name in supported:
            want = inspect.Parameter.empty if o.default is REQUIRED else o.default
            assert signature[o.name] == want, f"the accumulator's default of {o.name} is not its declaration's"
        elif o.name in UNSUPPORTED:
            assert signature[o.name] is None, f"the accumulator must default {o.name} to None (it refuses others)"


def test_unsupported_is_what_the_declarations_refuse():
    assert UNSUPPORTED == {"segments": "call break_segment() between records instead",
                           "decimate": "whiteness at the information rate needs the whole series",
                           "q": "give q (and dq, ddq) with each chunk: update(..., q=...)",
                           "estimation": "the estimation run's refit and repeat check need whole series",
                           "cross_correlation_detail": "the colour-aware cross-correlation needs the whole series; "
                                                       "rho is always given",
                           "model_columns": "the added-variable test projects whole columns"}


@pytest.mark.parametrize("name", sorted(UNSUPPORTED))
def test_the_accumulator_refuses_each_with_its_reason(name):
    with pytest.raises(InvalidParameter) as err:
        ValidationAccumulator(n_params=1, max_lag=2, **{name: [1, 2]})
    assert str(err.value) == f"{name} must be None for ValidationAccumulator ({UNSUPPORTED[name]}), got [1, 2]"


def test_check_options_checks_every_declaration_in_its_order(monkeypatch):
    seen: list[str] = []

    def spy(o: Option) -> Option:
        def check(value, c):
            seen.append(o.name)
            return o.check(value, c)
        return o._replace(check=check)

    monkeypatch.setattr(_options, "OPTIONS", tuple(spy(o) for o in OPTIONS))
    dynval.validate(np.arange(40.0), np.arange(40.0) + np.sin(np.arange(40.0)), n_params=1)
    assert seen == list(NAMES)


def test_a_bad_setting_is_named_in_the_contract_order():
    # two bad settings: the first declared wins (contract §2.1's order is OPTIONS')
    with pytest.raises(InvalidParameter, match=r"^level must be"):
        dynval.validate(np.arange(40.0), np.arange(40.0), n_params=1, level=2.0, allow_wide="yes")
    with pytest.raises(InvalidParameter, match=r"^max_lag must be"):
        dynval.validate(np.arange(40.0), np.arange(40.0), n_params=1, level=2.0, max_lag=-1)


def test_a_declared_option_reaches_the_check_and_the_command_line(monkeypatch):
    # what a new keyword needs besides its declaration is its use: the check, the flag and the
    # accumulator's part come from the declaration alone
    def check(value, c):
        if value is not None and value != 3:
            raise InvalidParameter(f"extra must be None or 3, got {value!r}")
        return value

    extra = Option("extra", "int or None", None, check, "a declared keyword", Flag("--extra", "an extra", "E", "int"))
    monkeypatch.setattr(_options, "OPTIONS", (*OPTIONS, extra))
    monkeypatch.setattr(_options, "NAMES", (*NAMES, "extra"))
    assert Keywords(n_params=1).extra is None
    with pytest.raises(InvalidParameter, match="extra must be None or 3, got 4"):
        check_options(Keywords(n_params=1, max_lag=2, decimate=None, cross_correlation_detail=None, extra=4), None)
    args = build_parser().parse_args(["validate", "m.npy", "p.npy", "--n-params", "1", "--extra", "3"])
    assert args.extra == 3


def test_keywords_refuse_unknown_names_and_need_n_params():
    with pytest.raises(TypeError, match="'max_lags'"):
        Keywords(n_params=1, max_lags=3)
    with pytest.raises(TypeError, match="n_params"):
        Keywords(max_lag=3)
    assert Keywords(n_params=1).decimate == "auto"


@pytest.mark.parametrize("command", [["validate", "m.npy", "p.npy", "--n-params", "1"],
                                     ["compare", "m.npy", "--model", "a=p.npy:1"]])
def test_the_command_line_flags_are_the_declarations(command):
    parser = build_parser()
    sub = next(a for a in parser._subparsers._group_actions if a.choices)  # argparse's own
    actions = {a.dest: a for a in sub.choices[command[0]]._actions}
    for o in OPTIONS:
        if o.flag is None:
            continue
        assert actions[o.name].option_strings == [o.flag.flag]
        assert actions[o.name].help == o.flag.help
    args = parser.parse_args(command)
    # a flag not given is the keyword's declared default (time_units_checked: the flag unsets it)
    for o in OPTIONS:
        if o.flag is not None:
            assert getattr(args, o.name) == o.default, o.name


def test_a_streamed_run_refuses_the_flags_the_stream_refuses(tmp_path, capsys):
    x = np.random.default_rng(0).normal(size=(200, 1))
    np.save(tmp_path / "m.npy", x)
    np.save(tmp_path / "p.npy", x)
    base = ["validate", str(tmp_path / "m.npy"), str(tmp_path / "p.npy"), "--n-params", "1", "--stream"]
    with pytest.raises(SystemExit):
        main([*base, "--decimate", "none", "--segments", "100,100"])
    assert "--segments, --decimate cannot be used with a streamed validation" in capsys.readouterr().err
    assert main([*base, "--time-units-unchecked", "--max-lag", "3", "--json"]) == 0


def test_the_contract_table_is_current():
    text = (ROOT / "docs" / "contract.md").read_text(encoding="utf-8")
    found = re.search(r"<!-- options-table:start -->\n(.*?)\n<!-- options-table:end -->", text, re.S)
    assert found is not None, "docs/contract.md §4 has no table of validate's keywords"
    assert found.group(1) == _options.options_table(), "run python -m dynval.coverage --write docs/contract.md"
    for o in OPTIONS:
        assert f"| `{o.name}` |" in found.group(1)


def test_a_merge_names_the_first_setting_that_differs_in_the_declared_order():
    # the settings two accumulators must share are the keywords the accumulator takes, compared in
    # the contract's order: n_joints comes before max_lag there (contract §4.1, merge)
    a = ValidationAccumulator(n_params=1, max_lag=2, n_joints=2)
    b = ValidationAccumulator(n_params=1, max_lag=3)
    with pytest.raises(InvalidParameter, match=r"same settings, got n_joints=None where this one has n_joints=2$"):
        a.merge(b)


def test_validate_docstring_states_the_declared_order_and_documents_every_keyword():
    doc = dynval.validate.__doc__
    said = re.search(r"Parameters are checked in the order\s+(.*?)\.\n", doc, re.S)
    assert said is not None
    names = [n.strip() for n in re.split(r",\s*", said.group(1).replace("\n", " "))]
    assert names == [*NAMES, "parameters"]
    documented = set(re.findall(r"^    (\w+)(?:, (\w+))? : ", doc, re.M))
    assert set(NAMES) <= {n for pair in documented for n in pair if n}


@pytest.mark.parametrize("name, bad", [("time_units_checked", "yes"), ("n_joints", 0)])
def test_a_fleet_checks_every_setting_a_stream_takes_before_any_log(tmp_path, name, bad):
    # the settings that need no data are the ones the stream checks before its chunks (contract §10)
    from dynval import fleet

    with pytest.raises(InvalidParameter, match=f"^{name} must be"):
        fleet.validate_many([str(tmp_path / "r01__2026-01-01")], n_params=1, scheduler="single", **{name: bad})


def test_the_accumulator_docstring_documents_what_it_takes_and_refuses():
    doc = ValidationAccumulator.__doc__
    refused = re.search(r"^    ([\w, ]+)\n        Not supported", doc, re.M)
    assert refused is not None
    assert set(refused.group(1).split(", ")) == set(UNSUPPORTED)
    documented = {n for line in re.findall(r"^    ([\w, ]+?)(?: : .*)?$", doc, re.M) for n in line.split(", ")}
    assert {o.name for o in OPTIONS if o.stream == "supported"} <= documented


@pytest.mark.parametrize("profile, max_lag, expected_lb", [("lesson", None, [50]), ("statsmodels", None, [10]),
                                                           ("statsmodels", 7, [10]), ("lesson", 0, [])])
def test_plan_lags_plans_the_ljung_box_lags_and_the_segment_lengths_once(profile, max_lag, expected_lb):
    # the lag phase, the stream and the provenance read these from Lags instead of asking again
    n = 1000
    starts = np.array([0, 300], dtype=np.int64)
    data = _options.Data(n=n, m=1, p=None, reg_shape=None, starts=starts, given_n=n, kept_rows=None,
                         meas=np.zeros((n, 1)))
    o = check_options(Keywords(n_params=1, profile=profile, max_lag=max_lag, segments=starts), data)
    lags = _options.plan_lags(o, n, starts)
    assert lags.lb_lags == expected_lb
    assert lags.lengths.tolist() == [300, 700] and lags.longest == 700


def test_plan_lags_with_the_motion_band_keeps_the_profile_count_for_the_decimated_test():
    fs, n = 200.0, 4000
    t = np.arange(n) / fs
    pred = np.sin(2 * np.pi * 2.0 * t)[:, None]  # the motion's power at 2 Hz: about 100 samples a period
    starts = np.array([0], dtype=np.int64)
    data = _options.Data(n=n, m=1, p=None, reg_shape=None, starts=starts, given_n=n, kept_rows=None, meas=pred)
    o = check_options(Keywords(n_params=1, sample_rate=fs, segments=starts), data)
    lags = _options.plan_lags(o, n, starts, pred)
    assert lags.source == _options.MOTION_LAG_SOURCE
    assert lags.band is not None and 2.0 <= lags.band <= 4.0  # the Welch bin holding the edge
    assert lags.max_lag == math.ceil(fs / lags.band) and lags.max_lag != 50
    assert lags.white_lag == 50 and lags.lb_lags == [lags.max_lag]  # the lesson's rule: one Ljung–Box lag, max_lag
