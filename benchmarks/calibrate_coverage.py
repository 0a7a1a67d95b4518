"""Calibration of the prediction band's coverage test (PredictionInterval.coverage_test, contract §9).

Each replicate simulates the friction scenario of dynval.simulate without noise (a new trajectory
per seed), adds the torque noise of the row (white, or AR(1) with coefficient 0.9 or 0.99, the same
stationary standard deviation 0.2 N·m on both runs), identifies the candidate on the estimation run
and tests its 95 % band on the validation run with q and q̇. The right model (``friction``) measures
the size: the share of replicates whose band fails on any joint (target ≤ α = 0.05). The friction-less
model (``rigid``) and a model without the Coulomb columns (``viscous``: the missing term is
sign(q̇)·Fc) measure the power (target ≥ 0.9). 95 % Clopper–Pearson intervals.

Run:  PYTHONPATH=python python3 benchmarks/calibrate_coverage.py [--replicates 200] [--quick]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.stats

from dynval.identify import identify
from dynval.simulate import COLUMN_NAMES, simulate

SIGMA = 0.2
NOISES = {"white": 0.0, "AR(1) 0.9": 0.9, "AR(1) 0.99": 0.99}
MODELS = {
    "friction": ("ZZ1R", "MX1R", "MY1", "ZZ2", "MX2", "MY2", "Fv1", "Fc1", "Fv2", "Fc2"),
    "rigid": ("ZZ1R", "MX1R", "MY1", "ZZ2", "MX2", "MY2"),
    "viscous": ("ZZ1R", "MX1R", "MY1", "ZZ2", "MX2", "MY2", "Fv1", "Fv2"),
}


def ar1(rng: np.random.Generator, shape: tuple[int, int], phi: float) -> np.ndarray:
    """AR(1) noise with stationary standard deviation SIGMA (started in its stationary law)."""
    w = rng.standard_normal(shape) * SIGMA * np.sqrt(1.0 - phi**2)
    out = np.empty(shape)
    out[0] = rng.standard_normal(shape[1]) * SIGMA
    for k in range(1, shape[0]):
        out[k] = phi * out[k - 1] + w[k]
    return out


def replicate(seed: int, phi: float, n_samples: int) -> dict[str, bool]:
    d = simulate("friction", seed=seed, noise=0.0, n_samples=n_samples)
    truth = np.array([d.true_parameters[c] for c in COLUMN_NAMES])
    rng = np.random.default_rng([seed, int(1000 * phi)])
    out = {}
    runs = {}
    for key, rec in (("est", d.estimation), ("val", d.validation)):
        runs[key] = (rec, rec.full_regressor @ truth + ar1(rng, rec.tau_meas.shape, phi))
    (est, tau_e), (val, tau_v) = runs["est"], runs["val"]
    for name, cols in MODELS.items():
        idx = [COLUMN_NAMES.index(c) for c in cols]
        fit = identify(est.full_regressor[:, :, idx], tau_e)
        band = fit.prediction_interval(val.full_regressor[:, :, idx])
        out[name] = not band.coverage_test(tau_v, q=val.q, dq=val.dq).passed
    return out


def clopper_pearson(k: int, n: int) -> tuple[float, float]:
    lo = 0.0 if k == 0 else float(scipy.stats.beta.ppf(0.025, k, n - k + 1))
    hi = 1.0 if k == n else float(scipy.stats.beta.ppf(0.975, k + 1, n - k))
    return lo, hi


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--replicates", type=int, default=200)
    parser.add_argument("--samples", type=int, default=2000, help="samples per run (100 Hz)")
    parser.add_argument("--quick", action="store_true", help="40 replicates")
    args = parser.parse_args(argv)
    reps = 40 if args.quick else args.replicates
    print(f"{'noise':<12}{'model':<10}{'rejected':>10}  95 % CI          ({reps} replicates, {args.samples} samples)")
    for noise, phi in NOISES.items():
        t0 = time.perf_counter()
        hits = {name: 0 for name in MODELS}
        for seed in range(reps):
            for name, failed in replicate(seed, phi, args.samples).items():
                hits[name] += failed
        for name in MODELS:
            lo, hi = clopper_pearson(hits[name], reps)
            role = "size" if name == "friction" else "power"
            print(f"{noise:<12}{name:<10}{hits[name] / reps:>10.3f}  [{lo:.3f}, {hi:.3f}]  {role}")
        print(f"  ({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
