"""
Physical consistency: a model can predict well and still be no robot
=====================================================================

The demo arm with loud torque noise, identified by least squares and under physical consistency
(every link's pseudo-inertia positive semidefinite, friction ≥ 0). Least squares estimates a
negative viscous friction; the constrained fit does not.
"""

from dynval.robots import URDFModel, physical_consistency, planar_arm_urdf
from dynval.simulate import ArmParameters, simulate

arm = ArmParameters(fv2=0.0)
data = simulate("friction", seed=3, arm=arm, noise=0.5)
model = URDFModel(planar_arm_urdf(arm))
est = data.estimation
ls = model.identify(est.q, est.dq, est.ddq, est.tau_meas, offset=False)
fit = model.identify(est.q, est.dq, est.ddq, est.tau_meas, offset=False, physical=True)
for finding in physical_consistency(ls):
    print("least squares:", finding.message)
print("under the constraints:", len(physical_consistency(fit)), "finding(s)")
