"""
A real arm: the KUKA LWR4+
==========================

Three logged runs of a 7-joint KUKA LWR4+ ship with dynval (``dynval.datasets``; the data are the
FloBaRoID project's, LGPL-3.0). A decoupled per-joint model (inertia, viscous and Coulomb friction,
gravity-like terms of the joint's own position) is identified on run 1 and validated on run 3, with
the time stamps, the derivatives' bandwidth, the positions and the estimation run.
"""

import matplotlib.pyplot as plt
import numpy as np

import dynval
import dynval.plot
from dynval.datasets import load_kuka_lwr4
from dynval.robots import differentiate

est, val = load_kuka_lwr4(1), load_kuka_lwr4(3)


def joint_model(run):
    d = differentiate(run.q, run.sample_rate)
    terms = [d.ddq, d.dq, np.sign(d.dq), np.sin(run.q), np.cos(run.q)]
    eye = np.eye(run.q.shape[1])
    return np.concatenate([x[:, :, None] * eye for x in terms], axis=2), d


y_est, _ = joint_model(est)
y_val, d = joint_model(val)
fit = dynval.identify(y_est, est.tau)
report = dynval.validate(val.tau, fit.predict(y_val), n_params=fit.rank, regressor=y_val, time=val.time,
                         bandwidth=d.input_bandwidth_hz, joint_names=list(val.joint_names),
                         estimation={"regressor": y_est, "tau": est.tau})
print(report.summary())

# %%
# Measured and predicted torque of two joints over the first seconds of the validation run.
fig = dynval.plot.prediction(val.tau[:, :2], fit.predict(y_val)[:, :2], sample_rate=val.sample_rate,
                             joint_names=list(val.joint_names[:2]), model_name="decoupled")
plt.show()
