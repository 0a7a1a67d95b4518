"""Unconstrained against physically consistent identification of the demo arm, compared on a new run.

The two-link arm of ``dynval.simulate`` (scenario ``friction``) with its elbow's viscous friction at
zero, the bound of the constraint, and loud torque noise (σ = 0.5 N·m): least squares is free to
estimate a viscous coefficient below zero, a friction that pushes. The arm is identified on its
estimation run twice, by least squares and under physical consistency (every link's pseudo-inertia
positive semidefinite, friction ≥ 0: ``URDFModel.identify(..., physical=True)``), and both, with
the true arm, are compared on the validation run, each bringing its parameters so that their
realizability is among the findings (``compare(..., {"name": {..., "parameters": fit}})``).

Run: ``PYTHONPATH=python python3 examples/physical_consistency/demo_arm.py`` (needs pinocchio, the
``robots`` extra, and cvxpy, the ``physical`` extra).
"""

from __future__ import annotations

import sys

import numpy as np


def main() -> int:
    try:
        import cvxpy  # noqa: F401
        import pinocchio  # noqa: F401
    except ImportError as exc:
        print(f"demo_arm: {exc.name} is not installed (pip install '.[robots,physical]'); skipping.")
        return 0
    import dynval
    from dynval.robots import URDFModel, physical_consistency, planar_arm_urdf
    from dynval.simulate import ArmParameters, simulate

    arm = ArmParameters(fv2=0.0)
    data = simulate("friction", seed=3, arm=arm, noise=0.5)
    model = URDFModel(planar_arm_urdf(arm))
    est, val = data.estimation, data.validation
    ls = model.identify(est.q, est.dq, est.ddq, est.tau_meas, offset=False)
    fit = model.identify(est.q, est.dq, est.ddq, est.tau_meas, offset=False, physical=True)
    names = model.column_names(offset=False)
    truth = model.parameters(offset=False)

    print("Demo arm (elbow viscous friction 0, torque noise 0.5 N·m): identified on the estimation run")
    print(f"  true arm: {len(physical_consistency(model))} physical-consistency finding(s)")
    for f in physical_consistency(ls):
        print(f"  least squares: {f.message}")
    print(f"  under the constraints: {len(physical_consistency(fit))} finding(s); d² = "
          f"{fit.physical['distance2']:.3g} from the least-squares estimate ({fit.physical['solver']}, "
          f"{fit.physical['solve_time']:.3f} s)")
    z_ls = (ls.estimate - ls.combination @ truth) / ls.std
    z_fit = (fit.estimate - fit.combination @ truth) / fit.std
    print(f"  base parameters, largest |estimate − truth| / σ: least squares {np.max(np.abs(z_ls)):.2f}, "
          f"constrained {np.max(np.abs(z_fit)):.2f}")
    for c in (names.index("Fv_elbow"), names.index("Fc_elbow")):
        print(f"  {names[c]}: truth {truth[c]:.3f}, constrained {fit.full_parameters[c]:.3f}")

    y = model.regressor(val.q, val.dq, val.ddq, offset=False)
    candidates = {
        "least squares": {"prediction": ls.predict(y), "n_params": ls.rank, "parameters": ls},
        "physical": {"prediction": fit.predict(y), "n_params": fit.rank, "parameters": fit},
        "true arm": {"prediction": model.predict(val.q, val.dq, val.ddq), "n_params": ls.rank, "parameters": model},
    }
    # the estimation run's regressor tells the structural columns (never excited by any motion of this
    # planar arm) from a flaw of the validation trajectory
    y_est = model.regressor(est.q, est.dq, est.ddq, offset=False)
    cmp = dynval.compare(val.tau_meas, candidates, regressor=y, column_names=list(names),
                         joint_names=["shoulder", "elbow"], q=val.q, dq=val.dq, ddq=val.ddq,
                         sample_rate=data.sample_rate, estimation={"q": est.q, "regressor": y_est, "tau": est.tau_meas})
    print()
    print(cmp.summary())
    return 0


if __name__ == "__main__":
    sys.exit(main())
