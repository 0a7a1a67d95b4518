"""Write the KUKA LWR4+ MJCF of dynval's package data from the shipped a-priori URDF.

    PYTHONPATH=python python3 examples/kuka_lwr4/mjcf_from_urdf.py [--identify] [--out FILE]

The bodies, joint origins, axes and inertials are the URDF's, written at full precision
(``repr`` of each number, ``fullinertia`` about the centre of mass in the body's frame: every
joint of this URDF has rpy = 0, so the frames are translations). ``mj_saveLastXML`` after MuJoCo's
own URDF import would round the inertias to six digits; written by hand, the two engines agree to
rounding (contract §11). The fixed ``box`` and ``lwr_base_link`` are kept (they carry no joint).

The joints' ``armature``, ``damping`` and ``frictionloss`` are the values below. They were chosen
with ``--identify``: on run 1, ``dynval.identify`` of the measured torque on this model's regressor
(``MJCFModel.regressor``: a known rigid-body column per joint, then q̈, q̇ and sign q̇ per joint),
printed with their standard deviations; the values kept are those estimates rounded to two
significant digits, with a negative estimate (a parameter MuJoCo refuses) set to zero. The
armature estimates are negative on five joints and the damping on four: the LWR's torque sensors
are on the link side of the gears, so the motors' inertia and most of their damping never reach
the measured torque, and what is left trades off against the CAD inertials' errors (the rigid-body
scale is fitted per joint too, between 0.33 and 0.95 on joints 1-6 and negative on the last).
"""

from __future__ import annotations

import argparse
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[1] / "python" / "dynval" / "datasets" / "data" / "kuka_lwr4"

#: per joint lwr_0_joint .. lwr_6_joint, from --identify on run 1 (see the module docstring)
ARMATURE = (0.0, 0.057, 0.0, 0.30, 0.0, 0.0, 0.0)
DAMPING = (1.3, 0.0, 0.065, 0.0, 0.0, 0.0, 0.0021)
FRICTIONLOSS = (0.57, 0.65, 0.17, 0.54, 1.0, 0.35, 0.082)


def _num(text: str | None) -> str:
    return " ".join(repr(float(x)) for x in (text or "0 0 0").split())


def _inertial(link: ET.Element) -> dict[str, str]:
    inertial = link.find("inertial")
    assert inertial is not None, link.get("name")
    origin = inertial.find("origin")
    assert origin is None or _num(origin.get("rpy")) == "0.0 0.0 0.0", "inertial frames must not be rotated"
    i = inertial.find("inertia").attrib  # type: ignore[union-attr]
    full = " ".join(repr(float(i[k])) for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz"))
    return {"pos": _num(origin.get("xyz") if origin is not None else None),
            "mass": repr(float(inertial.find("mass").get("value"))), "fullinertia": full}  # type: ignore[union-attr]


def build(urdf: Path, armature, damping, frictionloss) -> str:
    """The MJCF text of the URDF's chain, with the given joint parameters."""
    root = ET.parse(urdf).getroot()
    links = {link.get("name"): link for link in root.findall("link")}
    joints = {j.find("parent").get("link"): j for j in root.findall("joint")}  # type: ignore[union-attr]
    mj = ET.Element("mujoco", model="kuka_lwr4")
    ET.SubElement(mj, "compiler", angle="radian", autolimits="true")
    ET.SubElement(mj, "option", gravity="0 0 -9.81")
    parent, name, k = ET.SubElement(mj, "worldbody"), "box", 0
    body = ET.SubElement(parent, "body", name=name)
    while name in joints:
        joint = joints[name]
        origin = joint.findall("origin")[0]  # the URDF repeats the base joint's origin; pinocchio reads the first
        assert _num(origin.get("rpy")) == "0.0 0.0 0.0", "joint frames must not be rotated"
        name = joint.find("child").get("link")  # type: ignore[union-attr]
        body = ET.SubElement(body, "body", name=name, pos=_num(origin.get("xyz")))
        ET.SubElement(body, "inertial", _inertial(links[name]))
        if joint.get("type") == "revolute":
            limit = joint.find("limit")
            ET.SubElement(body, "joint", name=joint.get("name"), type="hinge",
                          axis=_num(joint.find("axis").get("xyz")),  # type: ignore[union-attr]
                          range=f"{float(limit.get('lower'))!r} {float(limit.get('upper'))!r}",  # type: ignore[union-attr]
                          armature=repr(float(armature[k])), damping=repr(float(damping[k])),
                          frictionloss=repr(float(frictionloss[k])))
            k += 1
    ET.indent(mj)
    return ("<!-- KUKA LWR4+ from FloBaRoID's kuka_lwr4.urdf (LGPL-3.0; see README.md here), written by\n"
            "     examples/kuka_lwr4/mjcf_from_urdf.py. Joint armature, damping and frictionloss: identified\n"
            "     on run 1 (that script's docstring). -->\n" + ET.tostring(mj, encoding="unicode") + "\n")


def identify_run1(text: str) -> None:
    """Print the simulator parameters identified on run 1 (estimate ± std per column)."""
    import dynval
    from dynval.datasets import load_kuka_lwr4
    from dynval.mjcf import MJCFModel

    run = load_kuka_lwr4(1)
    model = MJCFModel(text)
    fit = dynval.identify(model.regressor(run.q, run.dq, run.ddq), run.tau, column_names=model.column_names)
    for name, est, std in zip(fit.base_names, fit.estimate, fit.std):
        print(f"{name:28s} {est: .4g} ± {std:.2g}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--identify", action="store_true", help="print the parameters identified on run 1")
    parser.add_argument("--out", type=Path, default=DATA / "kuka_lwr4.xml")
    args = parser.parse_args(argv)
    zeros = np.zeros(7)
    if args.identify:
        identify_run1(build(DATA / "kuka_lwr4.urdf", zeros, zeros, zeros))
        return 0
    args.out.write_text(build(DATA / "kuka_lwr4.urdf", ARMATURE, DAMPING, FRICTIONLOSS), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
