"""
A log larger than memory: the streaming accumulator
===================================================

``dynval.stream.ValidationAccumulator`` takes the data in chunks of any length and gives the same
report as ``validate`` wherever both test; what a stream cannot test is named in its report.
"""

import numpy as np

import dynval
from dynval.stream import ValidationAccumulator

rng = np.random.default_rng(0)
tau_meas = rng.normal(size=(20_000, 3)) * [30.0, 10.0, 2.0]
tau_pred = tau_meas + rng.normal(scale=0.5, size=tau_meas.shape)

acc = ValidationAccumulator(n_params=12, max_lag=50)
for k in range(0, len(tau_meas), 4096):
    acc.update(tau_meas[k:k + 4096], tau_pred[k:k + 4096])
streamed = acc.result()
whole = dynval.validate(tau_meas, tau_pred, n_params=12, max_lag=50)
print("R² streamed", streamed.pooled["r2"], "in memory", whole.pooled["r2"])
print(streamed.summary())
