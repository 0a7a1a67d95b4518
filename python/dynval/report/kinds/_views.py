"""The motion's sections as the rules read them: one small typed view per section entry, built from
the section's mapping (the report's JSON form, contract §4), so that a rule reads attributes mypy
checks rather than string keys, and a renamed key fails where the view is built.

The views keep each value as the section holds it (a numpy float stays one): a rule that passes a
value on into a finding's details writes exactly what the section holds."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._base import Evidence

__all__ = ["JointPhysics", "Delay", "Periodic", "physics_joints", "physics_joint", "delay_of", "periodic_of"]


@dataclass(frozen=True)
class JointPhysics:
    """One joint's missing-physics test (``physics["tests"][j]``, conventions §5.2)."""

    joint: int  # its place in the section's list, which is the joint's index
    statistic: float
    share: float  # the library's share of the joint's mean square (nan when not tested)
    term: str | None  # the named group, None when none is named
    term_share: float
    selected: Sequence[str]
    shares: Mapping[str, float]
    selected_share: float
    n_eff: float
    refit_run: str | None  # "estimation", "validation", "absent", "stream", or None
    refit_shares: Mapping[str, float]  # each group's share in the refit that named the term (empty: none)
    heldout_share: float | None
    carried_share: float | None
    # the term's relation to the model's columns (statistics/_model_terms.relate): a record of
    # per-relation keys (contract §4, missing_physics' details["model_terms"]); None when unknown
    relation: Mapping[str, Any] | None

    @classmethod
    def of(cls, t: Mapping[str, Any], j: int) -> JointPhysics:
        return cls(joint=j, statistic=t["statistic"], share=t["share"], term=t["term"],
                   term_share=t["term_share"], selected=t["selected"], shares=t["shares"],
                   selected_share=t.get("selected_share", t["term_share"]), n_eff=t["n_eff"],
                   refit_run=t.get("refit_run"), refit_shares=t.get("refit_shares") or {},
                   heldout_share=t.get("heldout_share"),
                   carried_share=t.get("carried_share"), relation=t.get("relation"))

    @property
    def relation_name(self) -> str | None:
        """The relation's name (``"missing"``, ``"partial"``, …), None when unknown."""
        return None if self.relation is None else self.relation.get("relation")


@dataclass(frozen=True)
class Delay:
    """The delay test (``physics["delay"]``, conventions §5.2)."""

    share: np.ndarray  # (m,): the share of each joint's mean square realigning removes
    shift_samples: float

    @classmethod
    def of(cls, dl: Mapping[str, Any]) -> Delay:
        return cls(share=np.asarray(dl["share"], dtype=float), shift_samples=float(dl["shift_samples"]))


@dataclass(frozen=True)
class Periodic:
    """The periodic section's test of the error every period shares (conventions §5.9)."""

    effect_net: np.ndarray  # (m,)
    statistic: np.ndarray  # (m,)
    noise_variance: np.ndarray  # (m,)
    n_periods: int
    period: Any  # as the section states it: seconds (a float) or samples (an int)
    model_columns_removed: bool  # the model's columns were projected out before the test

    @classmethod
    def of(cls, per: Mapping[str, Any]) -> Periodic:
        return cls(effect_net=np.asarray(per["effect_net"], dtype=float), statistic=np.asarray(per["statistic"]),
                   noise_variance=np.asarray(per["noise_variance"]), n_periods=int(per["n_periods"]),
                   period=per["period"], model_columns_removed=bool(per.get("model_columns_removed", False)))


def physics_joints(ev: Evidence) -> list[JointPhysics]:
    """Every joint's missing-physics test, in joint order (empty without the physics section)."""
    return [] if ev.physics is None else [JointPhysics.of(t, j) for j, t in enumerate(ev.physics["tests"])]


def physics_joint(ev: Evidence, j: int) -> JointPhysics:
    """Joint j's missing-physics test (the physics section must be present)."""
    assert ev.physics is not None
    return JointPhysics.of(ev.physics["tests"][j], j)


def delay_of(ev: Evidence) -> Delay | None:
    """The delay test, None without one."""
    dl = ev.physics.get("delay") if ev.physics else None
    return None if dl is None else Delay.of(dl)


def periodic_of(ev: Evidence) -> Periodic | None:
    """The periodic section's test, None without one."""
    return None if ev.periodic is None else Periodic.of(ev.periodic)
