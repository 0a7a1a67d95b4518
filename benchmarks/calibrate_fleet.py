"""Calibration of the fleet drift test (dynval.fleet): size on healthy robots, power and the change's log.

Simulated fleets (dynval.fleet.simulate_fleet: the 2-DOF arm, each robot with its own masses and a
model identified on an estimation run of its own, coloured AR(1) torque noise, a new trajectory per log;
--model-error 0.03 gives every robot a model 3 % off its truth instead, the fleets of the recorded table
in benchmarks/README.md). Healthy fleets measure the
size: the share of healthy robots whose raw permutation p-value is ≤ α (the per-robot size, target
≤ α) and the share of fleets with any drift finding (the family-wise rate after Holm, target ≤ α).
Fleets with degrading robots measure the power (the degraded robot flagged) and whether the change
is placed at the right log (exactly, or within one log).

Each log's RMSE is computed as validate_many computes it (dynval.rmse, pooled per element), in
memory, so that many fleets run in minutes; tests/test_fleet.py runs the whole path on a small fleet.

Run:  PYTHONPATH=python python3 benchmarks/calibrate_fleet.py [--fleets 400 --power-fleets 100] [--model-error 0.03]
"""

from __future__ import annotations

import argparse
import math
import time

import dynval
from dynval.fleet import Degradation, LogSummary, simulate_fleet
from dynval.fleet._drift import drift_per_robot

ALPHA = 0.05
SCENARIOS = {
    "friction +30 % from log 8": Degradation("friction", 8, 0.3),
    "friction +15 % from log 6": Degradation("friction", 6, 0.15),
    "payload +1 kg from log 6": Degradation("payload", 6, 1.0),
    "payload +0.3 kg from log 9": Degradation("payload", 9, 0.3),
}


def rows_of(logs) -> list[LogSummary]:
    return [LogSummary(log.robot, log.time, f"{log.robot}#{i}", n_samples=log.tau_meas.shape[0], n_joints=2,
                       rmse=float(dynval.rmse(log.tau_meas, log.tau_pred)), decision="accept")
            for i, log in enumerate(logs)]


MODEL_ERROR = None  # --model-error


def fleet_drift(seed, n_robots, n_logs, n_samples, degradations=None, n_permutations=999):
    logs = simulate_fleet(n_robots=n_robots, n_logs=n_logs, n_samples=n_samples, degradations=degradations,
                          seed=seed, model_error=MODEL_ERROR)
    return drift_per_robot(rows_of(logs), level=1 - ALPHA, n_permutations=n_permutations, seed=seed)


def binomial_upper(k, n, z=1.96):
    """Wilson score upper bound of a rate (95 %)."""
    p = k / n
    centre = p + z * z / (2 * n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return (centre + half) / (1 + z * z / n)


def size(fleets, n_robots, n_logs, n_samples):
    raw = family = total = 0
    for seed in range(fleets):
        drift = fleet_drift(10_000 + seed, n_robots, n_logs, n_samples)
        raw += sum(d.pvalue <= ALPHA for d in drift)
        family += any(d.finding is not None for d in drift)
        total += len(drift)
    print(f"size, {fleets} healthy fleets of {n_robots} robots × {n_logs} logs × {n_samples} samples:")
    upper = binomial_upper(raw, total)
    print(f"  per robot (raw p ≤ {ALPHA}): {raw}/{total} = {raw / total:.4f} (95 % upper {upper:.4f})"
          f"  {'PASS' if raw / total <= ALPHA else 'MISS'}")
    print(f"  any finding in a fleet (Holm): {family}/{fleets} = {family / fleets:.4f}  "
          f"{'PASS' if family / fleets <= ALPHA else 'MISS'}")


def power(fleets, n_robots, n_logs, n_samples):
    print(f"power, {fleets} fleets per scenario (robot r02 degrades, {n_robots} robots × {n_logs} logs):")
    for name, change in SCENARIOS.items():
        flagged = exact = near = false = 0
        for seed in range(fleets):
            drift = fleet_drift(20_000 + seed, n_robots, n_logs, n_samples, {"r02": change})
            d = {x.robot: x for x in drift}["r02"]
            if d.finding is not None and d.finding.severity == "deficiency":
                flagged += 1
                exact += d.change == change.from_log
                near += abs(d.change - change.from_log) <= 1
            false += sum(x.finding is not None for x in drift if x.robot != "r02")
        print(f"  {name:<28} flagged {flagged / fleets:.3f}; at the right log {exact / fleets:.3f}, within one "
              f"{near / fleets:.3f}; healthy robots flagged {false}/{fleets * (n_robots - 1)}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fleets", type=int, default=400, help="healthy fleets for the size (default 400)")
    parser.add_argument("--power-fleets", type=int, default=100, help="fleets per degradation scenario (default 100)")
    parser.add_argument("--robots", type=int, default=6)
    parser.add_argument("--logs", type=int, default=12)
    parser.add_argument("--samples", type=int, default=1000)
    parser.add_argument("--model-error", type=float, default=None,
                        help="every robot's model this share off its truth (0.03: the recorded table) instead of "
                             "identified on an estimation run")
    args = parser.parse_args()
    global MODEL_ERROR
    MODEL_ERROR = args.model_error
    print(f"models: {'identified on an estimation run' if args.model_error is None else f'{args.model_error:g} off'}")
    start = time.perf_counter()
    size(args.fleets, args.robots, args.logs, args.samples)
    power(args.power_fleets, args.robots, args.logs, args.samples)
    print(f"({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
