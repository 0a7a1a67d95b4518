"""The first step is the strongest evidence (conventions §5.10), and compare marks what every
candidate shares (conventions §6).

Each test names the mutation it kills."""

from __future__ import annotations

import dataclasses
import json
from types import SimpleNamespace

import numpy as np
import pytest

import dynval
from dynval.comparison._compare import _verdict
from dynval.report._findings import Finding
from dynval.report._ranking import deciding, explained_share, first_reason, rank
from dynval.report._summary import format_deciding

NAMES = ["j1", "j2"]

# In rule order: a bias (|mean| = 0.3 RMSE: 9 % of the mean square), a missing column refitted on
# the estimation run (12 %), a missing physical term (its own share 62 %), whiteness.
BIAS = Finding(kind="bias", severity="deficiency", joints=(0,), effect=0.3, threshold=0.25,
               action="add a torque offset on j1", message="j1: residual mean.")
REFIT = Finding(kind="regressor_correlation", severity="deficiency", joints=(1,), columns=(3,), effect=0.12,
                threshold=0.01, action="add Fc2", message="j2: a term the model lacks: Fc2.",
                details={"added_variable": True, "method": "estimation_refit"})
PHYSICS = Finding(kind="missing_physics", severity="deficiency", joints=(1,), effect=0.9, threshold=0.05,
                  action="add viscous friction on j2", message="j2: the residual follows the motion.",
                  details={"term": "viscous", "term_share": 0.62})
WHITE = Finding(kind="whiteness", severity="deficiency", joints=(1,), action="see above",
                message="j2: not white.")
PERIODIC = Finding(kind="periodic_error", severity="deficiency", joints=(1,), effect=0.8, threshold=0.05,
                   action="see the physics findings", message="j2: every period shares 80 %.")


def test_each_kind_has_its_documented_share():
    """Kills: a share per kind other than conventions §5.10 says (ρ instead of ρ², |ē|/RMSE instead
    of its square, the library's share instead of the named term's, the wrong basis, a physical
    term's estimation refit read as a share on the validation run)."""
    assert explained_share(BIAS) == (pytest.approx(0.09), "validation", 0)
    assert explained_share(REFIT) == (0.12, "held_out", 1)
    assert explained_share(PHYSICS) == (0.62, "validation", 1)
    rho = Finding(kind="regressor_correlation", severity="deficiency", joints=(0,), columns=(1,), effect=0.5)
    assert explained_share(rho)[0] == pytest.approx(0.25)
    worse = Finding(kind="worse_than_constant", severity="deficiency", joints=(0,), statistic=-1.0, effect=1.0)
    assert explained_share(worse)[0] == pytest.approx(0.5)  # the mean torque leaves half the error
    chow = Finding(kind="predictive_failure", severity="deficiency", joints=(0,), statistic=4.0, effect=4.0)
    assert explained_share(chow) == (pytest.approx(0.75), "held_out", 0)
    delay = Finding(kind="delay", severity="deficiency", joints=(0, 1), effect=30.0,
                    details={"share": [0.02, 0.07]})
    assert explained_share(delay) == (0.07, "validation", 1)
    carried = Finding(kind="missing_physics", severity="deficiency", joints=(0,), effect=0.5,
                      details={"term_share": 0.4, "held_out_share": 0.3})
    assert explained_share(carried) == (0.3, "held_out", 0)
    # named by the refit on the estimation run: its term_share is carried to validation
    refit = dataclasses.replace(PHYSICS, details={**PHYSICS.details, "refit_run": "estimation"})
    assert explained_share(refit) == (0.62, "held_out", 1)
    fallback = dataclasses.replace(PHYSICS, details={**PHYSICS.details, "refit_run": "validation"})
    assert explained_share(fallback) == (0.62, "validation", 1)
    assert explained_share(WHITE)[0] is None


def test_the_strongest_deciding_finding_is_first_not_the_first_rule():
    """Kills: the first step taken from rule order (the bias here), whiteness ranked by its |ρ̂|, a
    structure-only finding (every period shares 80 %) ranked before the term that names its cause."""
    ranked = deciding([BIAS, REFIT, PERIODIC, PHYSICS, WHITE])
    assert [r.finding.kind for r in ranked] == ["missing_physics", "regressor_correlation", "bias",
                                                "periodic_error"]
    assert [r.leads for r in ranked] == [True, True, True, False]
    why = first_reason(ranked, NAMES)
    assert why.startswith("first because it explains 62 % of the residual's mean square on j2 (on the validation run)")
    assert "the largest of 3 deciding findings that name a cause (next: 12 %)" in why
    # whiteness is ranked (last) only when it is all there is
    assert [r.finding.kind for r in rank([WHITE, BIAS])] == ["bias", "whiteness"]
    assert [r.finding.kind for r in deciding([WHITE])] == ["whiteness"]
    # a structure-only finding on a joint where nothing names a cause leads by its share
    alone = Finding(kind="periodic_error", severity="deficiency", joints=(0,), effect=0.5)
    assert [r.finding.kind for r in deciding([REFIT, alone])] == ["periodic_error", "regressor_correlation"]


def test_validate_summary_and_json_give_the_ranked_list_and_why_first():
    """Kills: a report whose summary or JSON lacks the ranked list, or whose first step is the first
    rule's. A real report: joint 1 a small offset, joint 2 a large missing viscous term."""
    rng = np.random.default_rng(3)
    t = np.arange(6000) / 100.0
    q = np.c_[np.sin(2 * np.pi * 0.13 * t), np.sin(2 * np.pi * 0.11 * t + 1.0)]
    dq = np.gradient(q, t, axis=0)
    pred = np.c_[3.0 * q[:, 0], 2.0 * q[:, 1]]
    tau = pred + np.c_[0.05 + 0.1 * rng.normal(size=t.size), 1.5 * dq[:, 1] + 0.1 * rng.normal(size=t.size)]
    r = dynval.validate(tau, pred, n_params=2, sample_rate=100.0, q=q, joint_names=NAMES)
    d = json.loads(r.to_json())
    assert d["deciding"] and d["first_step"] == r.first_step == r.deciding[0].finding.action
    shares = [x["share"] for x in d["deciding"] if x["leads"] and x["share"] is not None]
    assert shares == sorted(shares, reverse=True) and d["deciding"][0]["joint_name"] == "j2"
    text = r.summary()
    block = text.split("Deciding findings, strongest first", 1)[1]
    assert f"Do first: {r.first_step}" in block and r.first_reason in block
    assert r.first_reason.startswith("first because it explains") and "on j2" in r.first_reason


def test_the_summary_block_lists_every_deciding_finding_with_its_share():
    """Kills: a block that drops the shares or the order."""
    lines = format_deciding(deciding([BIAS, PHYSICS]), NAMES)
    assert lines[2] == "  1. missing_physics on j2: 62 % on the validation run"
    assert lines[3] == "  2. bias on j1: 9 % on the validation run"
    assert lines[4] == "Do first: add viscous friction on j2"
    assert format_deciding([], NAMES) == []


def _report(*findings: Finding) -> SimpleNamespace:
    prov = {"joint_names": NAMES, "column_names": ["a", "b", "c", "Fc2"], "conventions": {"level": 0.95}}
    return SimpleNamespace(findings=list(findings), deficiencies=[f for f in findings if f.severity == "deficiency"],
                           whiteness={"lag": 20}, provenance=prov)


def _decide(reports: dict, crit: dict | None = None):
    names = list(reports)
    crit = crit or {n: float(k) for k, n in enumerate(names)}
    ranking = sorted(names, key=lambda n: (len(reports[n].deficiencies) > 0, crit[n], n))
    return _verdict(names, ranking, reports, "aic", crit)


def test_compare_refines_with_the_strongest_deficiency_first():
    """Kills: compare's first step and decided_by in rule order (the bias first)."""
    _, v = _decide({"a": _report(BIAS, REFIT, PHYSICS, WHITE)})
    assert v.decision == "refine"
    assert [d.kind for d in v.decided_by] == ["missing_physics", "regressor_correlation", "bias"]
    assert v.first_step == PHYSICS.action
    assert v.decided_by[0].share == 0.62 and v.decided_by[1].share_basis == "held_out"
    assert v.reasons[0].startswith(PHYSICS.message) and v.reasons[-1].startswith(WHITE.message)
    assert v.first_reason.startswith("first because it explains 62 %")
    assert "do first: add viscous friction on j2" in v.summary() and v.first_reason in v.summary()


def test_findings_every_candidate_has_are_marked_shared():
    """Kills: shared decided from the words (the two biases' messages differ), or marking a finding
    shared when one candidate has that kind on another joint only."""
    bias_b = Finding(kind="bias", severity="deficiency", joints=(0,), effect=0.5, threshold=0.25,
                     action="add an offset", message="j1: a differently worded mean.")
    other = Finding(kind="bias", severity="deficiency", joints=(1,), effect=0.5, threshold=0.25,
                    action="add an offset", message="j2: residual mean.")
    reports = {"good": _report(BIAS, REFIT), "weak": _report(bias_b)}
    from dynval.comparison._compare import _matter
    from dynval.comparison._reasons import candidate_reasons

    matter = _matter(list(reports), reports)
    assert [(f.kind, sh) for f, _, sh in matter["good"]] == [("regressor_correlation", False), ("bias", True)]
    assert [(f.kind, sh) for f, _, sh in matter["weak"]] == [("bias", True)]
    reasons = candidate_reasons(["good", "weak"], reports, "aic", {"good": 1.0, "weak": 2.0}, matter)
    assert reasons["good"][1].endswith("— shared by all candidates")
    assert not reasons["good"][0].endswith("shared by all candidates")
    # the bias's reason carries the share it explains (9 %), which its effect (|ē|/RMSE) does not print
    assert "explains 9 % of the joint's residual" in reasons["good"][1]
    # on another joint it is not shared
    matter = _matter(["good", "weak"], {"good": _report(BIAS), "weak": _report(other)})
    assert [sh for _, _, sh in matter["good"]] == [False]
    # a single candidate shares nothing with anyone
    assert [sh for _, _, sh in _matter(["good"], {"good": _report(BIAS)})["good"]] == [False]
    # the verdict's records carry the mark
    _, v = _decide({"good": _report(BIAS, REFIT), "weak": _report(bias_b)}, {"good": 1.0, "weak": 2.0})
    assert [(d.kind, d.shared) for d in v.decided_by] == [("regressor_correlation", False), ("bias", True)]
    assert "shared by all candidates" in v.decided_by[1].label()


def test_design_findings_are_said_once_by_their_record_not_their_words():
    """Kills: the design findings of several candidates de-duplicated by message: the same repeat
    worded twice differently is one reason, two different unexcited columns are two."""
    a = Finding(kind="repeat_trajectory", severity="design", effect=0.9, action="validate elsewhere",
                message="The validation run repeats the estimation run (0.9).")
    b = Finding(kind="repeat_trajectory", severity="design", effect=0.8, action="validate elsewhere",
                message="The validation run repeats the estimation run (0.8).")
    _, v = _decide({"x": _report(a), "y": _report(b)})
    assert v.decision == "redesign" and len(v.reasons) == 1
    c1 = Finding(kind="excitation", severity="design", columns=(0,), action="excite a", message="never excites.")
    c2 = Finding(kind="excitation", severity="design", columns=(1,), action="excite b", message="never excites.")
    _, v = _decide({"x": _report(c1), "y": _report(c2)})
    assert len(v.reasons) == 2


def test_joints_are_compared_by_the_share_of_their_torque():
    """70 % of a large error before 90 % of a small one: with the joints' R² the effect is the share
    of each joint's measured-torque variance. Kills: ranking across joints by the share of each
    joint's own residual (the elbow's tiny error first, the calibration's no_gravity rows)."""
    shoulder = Finding(kind="missing_physics", severity="deficiency", joints=(0,), effect=0.9,
                       details={"term": "gravity", "term_share": 0.7}, action="add gravity on j1")
    elbow = Finding(kind="missing_physics", severity="deficiency", joints=(1,), effect=0.95,
                    details={"term": "position_harmonic", "term_share": 0.9}, action="add a harmonic on j2")
    assert [r.finding.joints for r in deciding([elbow, shoulder])] == [(1,), (0,)]  # shares alone
    ranked = deciding([elbow, shoulder], r2=[0.95, 0.99])
    assert [r.finding.joints for r in ranked] == [(0,), (1,)]
    assert ranked[0].torque_share == pytest.approx(0.035) and ranked[1].torque_share == pytest.approx(0.009)
    assert "3.5 % of the measured torque's variance there" in first_reason(ranked, NAMES)


def test_one_missing_column_is_one_step_over_every_joint_it_helps():
    """A column whose refit removes 50 % on each of two joints (1 % of each torque) outranks a term
    that removes 90 % of one joint's residual (1.8 %). Kills: the column's findings ranked one by one."""
    col = [Finding(kind="regressor_correlation", severity="deficiency", joints=(j,), columns=(3,), effect=0.5,
                   details={"added_variable": True, "method": "estimation_refit"}, action="add Fc2") for j in (0, 1)]
    other = Finding(kind="missing_physics", severity="deficiency", joints=(1,), effect=0.9,
                    details={"term": "offset", "term_share": 0.9}, action="add an offset on j2")
    ranked = deciding([other, *col], r2=[0.98, 0.98])
    assert [r.finding.kind for r in ranked] == ["regressor_correlation", "regressor_correlation", "missing_physics"]


def test_a_missing_column_ranks_with_what_it_removes_on_the_joints_it_does_not_act_on():
    """The planar arm without L1:mz: the estimation fit bends L2:mz to make up for it, so the elbow
    carries most of the error, which adding L1:mz (a shoulder column) removes through the refit.
    Kills: the indirect effect left out of the column's rank (the elbow's own finding first, 62 %
    against the column's 12 % + 55 %), or counted twice."""
    col = Finding(kind="regressor_correlation", severity="deficiency", joints=(0,), columns=(3,), effect=0.12,
                  threshold=0.01, action="add the term L1:mz", message="j1: a term the model lacks: L1:mz.",
                  details={"added_variable": True, "method": "estimation_refit", "indirect": {1: 0.55}})
    assert [r.finding.kind for r in deciding([PHYSICS, col])] == ["regressor_correlation", "missing_physics"]
    # the reason says what made it first: its effect on the joint it does not act on too
    why = first_reason(deciding([PHYSICS, col], [0.5, 0.5]), NAMES)
    assert "and, added alone, 55 % on j2 (the parameters the fit bent there; 28 % of the torque's variance" in why
    assert "and, added alone" not in first_reason(deciding([PHYSICS]), NAMES)
    less = dataclasses.replace(col, details={**col.details, "indirect": {1: 0.4}})
    assert [r.finding.kind for r in deciding([PHYSICS, less])] == ["missing_physics", "regressor_correlation"]


def test_a_model_columns_correlation_follows_the_structure_the_model_lacks_on_its_joint():
    """A decoupled model of a coupled arm: the residual correlates with the joint's own sin q_j (the
    missing coupling's trace on it) beside the physics finding that names the coupling. Kills:
    "re-identify the term of sin2" taken as the first step there (re-identifying the column does not
    add the coupling); the rule applied where the model has the term (a friction changed between
    runs: "re-identify the term of Fc2" stays the step), to a missing column's refit, or to a column
    the lacking structure is not aligned with."""
    trace = Finding(kind="regressor_correlation", severity="deficiency", joints=(1,), columns=(13,), effect=0.8,
                    threshold=0.1, action="re-identify the term of sin2 on j2", message="j2: correlates with sin2.",
                    details={"lag": 0, "rho": 0.8, "in_model": True})
    coupling = dataclasses.replace(PHYSICS, details={**PHYSICS.details, "relation": "coupling",
                                                       "model_terms": {"columns": [13, 12]}})
    assert [r.finding.kind for r in deciding([trace, coupling])] == ["missing_physics", "regressor_correlation"]
    assert [r.leads for r in deciding([trace, coupling])] == [True, False]
    changed = dataclasses.replace(PHYSICS, details={**PHYSICS.details, "relation": "reweight"})
    assert [r.finding.kind for r in deciding([trace, changed])] == ["regressor_correlation", "missing_physics"]
    lacks = dataclasses.replace(trace, details={**trace.details, "in_model": False})
    assert [r.finding.kind for r in deciding([lacks, coupling])] == ["regressor_correlation", "missing_physics"]
    # the same column on another joint: a parameter the joints share, which the fit bent to make up
    # for the structure the model lacks (an elbow's rotor inertia bends L3:Iyy, which the shoulder's
    # residual then correlates with): it follows too
    elsewhere = dataclasses.replace(trace, joints=(0,))
    assert deciding([elsewhere, coupling])[0].finding is coupling
    # another column than the ones the lacking structure is aligned with (a changed Coulomb column
    # beside an offset the model lacks): the correlation keeps its place
    other = dataclasses.replace(trace, columns=(6,))
    assert deciding([other, coupling])[0].finding is other


def test_a_joints_reweighting_follows_a_structure_missing_where_its_columns_are_shared():
    """The planar arm without L1:mz, the column not offered: the elbow's error (its own L2:* columns
    with other weights) is the bend the missing shoulder term leaves in the shared parameters; the
    shoulder's lacking posture term is the step. Kills: the rule dropped (the elbow's 97 % first);
    applied when the re-weighted columns do not enter the lacking joint (a changed friction Fc2 on
    the elbow beside a shoulder term: the friction stays first); applied when nothing lacks; an
    offset the names say the model lacks but that lies in the span of the re-weighted columns
    (outside share ≈ 0) counted as a lacking structure or left leading."""
    elbow = Finding(kind="missing_physics", severity="deficiency", joints=(1,), effect=0.97, threshold=0.05,
                    action="re-identify the model's terms on j2", message="j2: follows the motion.",
                    details={"term": "position_harmonic", "term_share": 0.97, "relation": "unsupported",
                             "model_terms": {"relation": "unsupported", "reweight_share": 0.97,
                                             "outside_share": 0.0, "columns": [3, 4], "shared_with": [0]}})
    shoulder = Finding(kind="missing_physics", severity="deficiency", joints=(0,), effect=0.43, threshold=0.05,
                       action="complete a gravity term on j1", message="j1: follows the motion.",
                       details={"term": "gravity", "term_share": 0.43, "relation": "partial",
                                "model_terms": {"relation": "partial", "reweight_share": -0.3,
                                                "outside_share": 1.0, "columns": [0, 3], "shared_with": [1]}})
    trace = Finding(kind="regressor_correlation", severity="deficiency", joints=(1,), columns=(4,), effect=0.8,
                    threshold=0.1, action="re-identify the term of L2:mz on j2", message="j2: correlates.",
                    details={"lag": 0, "rho": 0.8, "in_model": True})
    r2 = [0.97, 0.91]
    assert [r.finding for r in deciding([elbow, trace, shoulder], r2)] == [shoulder, elbow, trace]
    own = dataclasses.replace(elbow, details={**elbow.details, "model_terms": {
        **elbow.details["model_terms"], "shared_with": []}})
    assert deciding([own, trace, shoulder], r2)[0].finding is own
    assert deciding([elbow, trace], r2)[0].finding is elbow
    # an elbow offset the names say the model lacks, in the span of L2:mx on this slow run
    offset = dataclasses.replace(elbow, details={**elbow.details, "term": "offset", "relation": "missing",
                                                 "model_terms": {**elbow.details["model_terms"],
                                                                 "relation": "missing", "outside_share": 1e-6}})
    assert deciding([offset, shoulder], r2)[0].finding is shoulder
    outside = dataclasses.replace(offset, details={**offset.details, "model_terms": {
        **offset.details["model_terms"], "outside_share": 0.9}})
    assert deciding([outside, shoulder], r2)[0].finding is outside


def test_a_model_columns_correlation_follows_any_group_the_lacking_structure_took_in():
    """A decoupled arm's shoulder: inertia coupling is the term named, gravity coupling entered with
    it, and the residual correlates with the joint's own sin2 (gravity's trace) or with ddq3 first and
    sin3 after it. Kills: only the named group's aligned columns counted (sin2 first: "re-identify the
    term of sin2"), or only the correlation's first column looked at."""
    coupling = dataclasses.replace(PHYSICS, details={**PHYSICS.details, "term": "inertia", "relation": "coupling",
                                                       "model_terms": {"columns": [1, 2], "trace_columns": [1, 2, 13]}})
    sin2 = Finding(kind="regressor_correlation", severity="deficiency", joints=(1,), columns=(13,), effect=0.9,
                   threshold=0.1, action="re-identify the term of sin2 on j2", message="j2: correlates with sin2.",
                   details={"lag": 0, "rho": 0.9, "in_model": True})
    assert deciding([sin2, coupling])[0].finding is coupling
    named_only = dataclasses.replace(coupling, details={**coupling.details, "model_terms": {"columns": [1, 2]}})
    assert deciding([sin2, named_only])[0].finding is sin2
    ddq_first = dataclasses.replace(sin2, columns=(5, 13))
    assert deciding([ddq_first, coupling])[0].finding is coupling


def _local_finding(shares):
    """A joint-local term on j2 (relation ``local``) whose refit removes ``shares`` on (j1, j2)."""
    return Finding(kind="missing_physics", severity="deficiency", joints=(1,), effect=0.9, threshold=0.05,
                   action="add a rotor inertia J_a·q̈ on j2 alone", message="j2: local.",
                   details={"term": "inertia", "term_share": 0.7, "relation": "local",
                            "model_terms": {"relation": "local", "outside_share": 0.0, "reweight_share": 0.8,
                                            "local": {"group": "inertia", "columns": 1, "share": shares[1],
                                                      "shares": list(shares)}}})


@pytest.mark.parametrize("on_j1, follows", [(0.9, True), (0.3, False)])
def test_a_joint_local_term_ranks_by_its_refit_and_the_joints_it_explains_follow(on_j1, follows):
    """A joint-local term's share is its refit's on its joint (held out), what the refit removes on
    the other joints counts in its rank, and the findings of a joint it removes at least half of
    follow it. Kills: its share taken from the library's term share, its effect elsewhere not
    counted, _FOLLOWS not applied (or applied below its half)."""
    local = _local_finding((on_j1, 0.6))
    assert explained_share(local) == (0.6, "held_out", 1)
    # j1's larger own error: a predictive failure and a correlation with a model column
    chow = Finding(kind="predictive_failure", severity="deficiency", joints=(0,), statistic=5.0, effect=5.0)
    rho = Finding(kind="regressor_correlation", severity="deficiency", joints=(0,), columns=(2,), effect=0.9,
                  details={"in_model": True})
    r2 = [0.5, 0.9]  # j1's residual is half its torque, j2's a tenth
    ranked = rank([chow, rho, local], r2)
    lead = {r.finding.kind: r.leads for r in ranked}
    if follows:
        assert ranked[0].finding is local and not lead["predictive_failure"] and not lead["regressor_correlation"]
        # its rank counts j1's 90 % of a residual that is half the torque
        assert ranked[0].indirect_torque == pytest.approx(0.9 * 0.5)
        assert "90 % on j1" in first_reason(ranked, NAMES)
    else:
        assert lead["regressor_correlation"] and ranked[0].finding is not local


def test_a_delay_is_judged_on_the_joint_where_it_explains_the_most_of_the_torque():
    """One shift realigns every joint: its effect is its largest share of a joint's measured torque
    (share × (1 − R²)), not the torque share of the joint where its share of the residual is largest
    (delay:white:arm4@1000 replicate 12: 51 % of the base's tiny residual ranked after 26 % of the wrist's).
    Kills: the joint chosen by the residual's share alone (then the wrist's correlation leads)."""
    delay = Finding(kind="delay", severity="deficiency", joints=(0, 1, 2), effect=3.0, threshold=1.0,
                    action="realign", message="a delay", details={"share": [0.5, 0.1, 0.45]})
    wrist = Finding(kind="regressor_correlation", severity="deficiency", joints=(1,), columns=(2,), effect=0.45,
                    threshold=0.1, action="re-identify", message="j2: a column", details={"in_model": True})
    r2 = [1.0 - 0.001, 1.0 - 0.01, 1.0 - 0.006]
    assert explained_share(delay, r2) == (0.45, "validation", 2)
    assert explained_share(delay) == (0.5, "validation", 0)  # without R², the residual's share decides
    ranked = rank([wrist, delay], r2)
    assert ranked[0].finding.kind == "delay"
    assert ranked[0].torque_share == pytest.approx(0.45 * 0.006)


@pytest.mark.parametrize("on_j1, follows", [(0.9, True), (0.3, False)])
def test_a_term_the_model_lacks_counts_what_its_own_columns_remove_on_the_other_joints(on_j1, follows):
    """A term the model lacks (relation ``partial``) with its own columns added on its joint alone
    (``model_terms.added_alone``): what that refit removes on the other joints counts in its rank,
    and a joint it removes at least half of follows it (stribeck:ar0.9:arm6@200: the shoulder's
    missing Stribeck friction bent the parameters the wrists' re-weightings then led with).
    Kills: ``added_alone`` not read (only a joint-local term's refit counted)."""
    partial = Finding(kind="missing_physics", severity="deficiency", joints=(1,), effect=0.9, threshold=0.05,
                      action="complete Coulomb friction on j2", message="j2: partial.",
                      details={"term": "coulomb", "term_share": 0.4, "relation": "partial",
                               "model_terms": {"relation": "partial", "outside_share": 0.5, "reweight_share": 0.3,
                                               "added_alone": {"group": "coulomb", "columns": 5, "share": 0.4,
                                                               "shares": [on_j1, 0.4]}}})
    bent = Finding(kind="missing_physics", severity="deficiency", joints=(0,), effect=0.9, threshold=0.05,
                   action="re-identify Coulomb friction on j1", message="j1: reweight.",
                   details={"term": "coulomb", "term_share": 0.9, "relation": "reweight",
                            "model_terms": {"relation": "reweight", "outside_share": 0.0, "reweight_share": 0.9}})
    r2 = [0.5, 0.9]
    ranked = rank([bent, partial], r2)
    lead = {r.finding.action: r.leads for r in ranked}
    if follows:
        assert ranked[0].finding is partial and not lead[bent.action]
        assert ranked[0].indirect_torque == pytest.approx(0.9 * 0.5)
        assert "90 % on j1" in first_reason(ranked, NAMES)
    else:
        assert ranked[0].finding is bent and lead[bent.action]


def _posture(joint: int, relation: str, shared: list[int], share: float, term: str = "gravity",
             in_group: bool = True) -> Finding:
    return Finding(kind="missing_physics", severity="deficiency", joints=(joint,), effect=0.99, threshold=0.05,
                   action=f"complete a {term} term on j{joint + 1}", message="follows the posture.",
                   details={"term": term, "term_share": share, "relation": relation,
                            "model_terms": {"relation": relation, "reweight_share": 0.77, "outside_share": 0.23,
                                            "model_in_group": in_group, "columns": [2], "shared_with": shared}})


@pytest.mark.parametrize("mutant", [None, "relation", "term", "held_here", "not_shared", "note"])
def test_a_rigid_body_term_the_model_holds_follows_a_kind_it_holds_nothing_of_elsewhere(mutant):
    """A gravity-only 7-joint arm (gravity_only:white:arm7@100, replicates 2 and 14): the model holds
    no inertia on the base joint, and least squares bent the posture parameters the joints share to
    stand for it; the elbow's "complete a position-dependent term" (its part outside the span 23 %)
    is that bend and follows the base joint's missing inertia, though its share of the torque is
    larger (conventions §5.10). Kills: the rule dropped; applied when the lacking term is not a
    rigid-body kind (a missing Coulomb friction), when the model holds some of it there (relation
    partial), when the bent term is not a kind the model holds on its joint, when the joints share
    no parameter, when the lacking finding is a note."""
    base = Finding(kind="missing_physics", severity="deficiency", joints=(0,), effect=0.99, threshold=0.05,
                   action="add an inertial term on j1", message="j1: follows the motion.",
                   details={"term": "inertia", "term_share": 0.28, "relation": "missing",
                            "model_terms": {"relation": "missing", "reweight_share": 0.09, "outside_share": 0.48,
                                            "model_in_group": False, "columns": [0], "shared_with": []}})
    elbow = _posture(2, "partial", [0, 1, 3], 0.995)
    if mutant == "relation":
        base = dataclasses.replace(base, details={**base.details, "relation": "partial"})
    elif mutant == "term":
        base = dataclasses.replace(base, details={**base.details, "term": "coulomb"})
    elif mutant == "held_here":
        elbow = _posture(2, "partial", [0, 1, 3], 0.995, in_group=False)
    elif mutant == "not_shared":
        elbow = _posture(2, "partial", [1, 3], 0.995)
    elif mutant == "note":
        base = dataclasses.replace(base, severity="note")
    r2 = [0.27, 0.93, 0.76]  # the elbow's 99.5 % is 24 % of its torque, the base's 28 % is 20 %
    ranked = deciding([elbow, base], r2)
    if mutant is None:
        assert [r.finding for r in ranked] == [base, elbow]
        assert not ranked[1].leads
        why = first_reason(ranked, ["j1", "j2", "j3"])
        assert "error shared parameters carry for a structure another joint lacks" in why
    else:
        assert ranked[0].finding is elbow


def test_a_gravity_only_arm_is_told_to_add_inertia_before_the_posture_terms_it_bent():
    """gravity_only:white:arm7@100 replicate 2 (the unit test above, on the simulated arm): the
    elbow's partial posture term explained more of its torque than the base joint's missing inertia
    and led. Kills: the rule dropped."""
    from dynval import scenarios

    s = next(x for x in scenarios.library() if x.key == "gravity_only:white:arm7@100")
    rep = scenarios.simulate(s, 2)
    report = scenarios.validate_replicate(rep, False, prediction=scenarios.fit(rep))
    first = report.deciding[0].finding
    assert first.kind == "missing_physics" and first.details["term"] == "inertia" and first.joints == (0,)
    assert scenarios.advice_right(report, s, False, rep.model_columns)


def test_a_model_columns_correlation_larger_than_the_lacking_structure_is_its_own_weight():
    """A Coulomb friction changed between runs on a planar arm under AR(1) noise: the residual
    correlates with the model's own Fc1 (ρ = 0.88, 77 % of the shoulder's residual) beside an offset
    the model lacks that removes 8 % there and took the Coulomb group in with it (Fc1 among its trace
    columns). A trace is part of the structure, never larger: "re-identify the term of Fc1" is the
    step. Kills: the correlation made to follow whatever its size (the 8 % offset first); the share
    compared the wrong way round; the condition applied to the bend of a parameter shared with
    another joint, which follows the structure lacking there whatever its size."""
    fc1 = Finding(kind="regressor_correlation", severity="deficiency", joints=(0,), columns=(6,), effect=0.88,
                  threshold=0.1, action="re-identify the term of Fc1 on j1", message="j1: correlates with Fc1.",
                  details={"lag": 0, "rho": 0.88, "in_model": True})
    offset = Finding(kind="missing_physics", severity="deficiency", joints=(0,), effect=0.3, threshold=0.05,
                     action="add a torque offset on j1", message="j1: the residual follows the motion.",
                     details={"term": "offset", "term_share": 0.08, "relation": "missing",
                              "model_terms": {"columns": [0], "trace_columns": [0, 6]}})
    assert [r.finding for r in deciding([fc1, offset])] == [fc1, offset]
    assert deciding([fc1, offset])[0].leads
    # a structure that removes at least half of what the correlation explains leaves it as its trace
    larger = dataclasses.replace(offset, details={**offset.details, "term_share": 0.45})
    assert [r.finding for r in deciding([fc1, larger])] == [larger, fc1]
    smaller = dataclasses.replace(offset, details={**offset.details, "term_share": 0.3})
    assert deciding([fc1, smaller])[0].finding is fc1
    # the same column on the other joint: the fit bent the shared parameter for the structure lacking
    # there, whatever that structure's size on its own joint
    bent = dataclasses.replace(fc1, joints=(1,))
    assert deciding([bent, offset])[0].finding is offset
    # at the bound (ρ = 0.5: ρ² = 0.25, half of it 0.125, exact in binary) the correlation follows;
    # just below it, it leads; of two lacking structures on the column the larger counts; a structure
    # of unknown share keeps the correlation following
    half = dataclasses.replace(fc1, effect=0.5)
    at = dataclasses.replace(offset, details={**offset.details, "term_share": 0.125})
    below = dataclasses.replace(offset, details={**offset.details, "term_share": 0.12})
    assert deciding([half, at])[0].finding is at
    assert deciding([half, below])[0].finding is half
    assert deciding([half, at, below])[0].finding is at
    unknown = dataclasses.replace(offset, effect=None, details={
        k: v for k, v in offset.details.items() if k != "term_share"})
    assert rank([half, unknown])[0].finding is unknown
    # where the model holds part of the kind (a decoupled model's own gravity columns beside the coupling
    # it lacks: decoupled:white:arm4@100 replicate 67, ρ² 0.685 with sin2 against the coupling's 0.289),
    # the fit bends the columns it has: their correlation follows the structure whatever its size
    for relation in ("coupling", "partial", "local"):
        held = dataclasses.replace(offset, details={**offset.details, "relation": relation,
                                                    "model_terms": {"columns": [6], "trace_columns": [6]}})
        assert deciding([fc1, held])[0].finding is held, relation
        # a column of another group the selection took in with it is a trace like any other: bounded
        other_group = dataclasses.replace(held, details={**held.details,
                                                         "model_terms": {"columns": [0], "trace_columns": [0, 6]}})
        assert deciding([fc1, other_group])[0].finding is fc1, relation
    # a correlation of unknown size is no larger than the structure: it follows, as before the bound
    unsized = dataclasses.replace(fc1, effect=None)
    assert [r.leads for r in rank([unsized, offset])] == [True, False]
