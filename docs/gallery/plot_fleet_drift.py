"""
A fleet of robots: which one drifts, from which log
===================================================

Six simulated robots with twelve logs each; robot ``r03``'s friction rises by 30 % from its seventh
log. ``dynval.fleet.validate_many`` validates every log and tests each robot for drift (a change
point in its logs' RMSE with a permutation p-value, Holm over the robots).
"""

import tempfile

import matplotlib.pyplot as plt

import dynval.fleet as fleet
import dynval.plot

with tempfile.TemporaryDirectory() as where:
    logs = fleet.simulate_fleet(n_robots=6, n_logs=12, degradations={"r03": fleet.Degradation("friction", 7, 0.3)})
    fleet.write_fleet(logs, where)
    result = fleet.validate_many(f"{where}/manifest.csv", max_lag=20, progress=False)
print(result.summary())

# %%
fig = dynval.plot.fleet_drift(result)
plt.show()
