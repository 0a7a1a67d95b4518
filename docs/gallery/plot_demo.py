"""
The demo arm: three candidate models, one verdict
=================================================

The 2-DOF arm of ``dynval.simulate`` with Coulomb and viscous friction: three model structures are
identified on an estimation run and compared on a validation run. The rigid-body model without
friction leaves a structure in its residual that the friction model explains; ``compare`` ranks the
candidates, names the findings that decided and gives the verdict.
"""

import matplotlib.pyplot as plt

import dynval
import dynval.plot
from dynval.simulate import CANDIDATES, COLUMN_NAMES, simulate

data = simulate("friction", seed=0)
est, val = data.estimation, data.validation
candidates = {}
for name in CANDIDATES:
    cols = [COLUMN_NAMES.index(c) for c in CANDIDATES[name]]
    fit = dynval.identify(est.full_regressor[:, :, cols], est.tau_meas)
    candidates[name] = {"prediction": fit.predict(val.full_regressor[:, :, cols]), "n_params": fit.rank,
                        "model_columns": cols}

cmp = dynval.compare(val.tau_meas, candidates, regressor=val.full_regressor, column_names=list(COLUMN_NAMES),
                     sample_rate=data.sample_rate, joint_names=list(data.joint_names), q=val.q,
                     estimation={"q": est.q, "regressor": est.full_regressor, "tau": est.tau_meas})
print(cmp.summary())

# %%
# The residual's autocorrelation of the shoulder joint for each candidate: the model without
# friction leaves a slow structure that the friction model removes.
fig = dynval.plot.autocorrelation_by_model(cmp.reports, joint=0, chosen=cmp.ranking[0])
plt.show()
