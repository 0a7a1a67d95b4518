"""Real robot data that ship with dynval, loaded like ``sklearn.datasets``.

``import dynval`` does not import this module and reads no data file: a loader reads its files when
it is called, and every call returns fresh, read-only arrays.

* :func:`load_kuka_lwr4`: three logged runs of a KUKA LWR4+ (7 joints, 5027 samples at 200 Hz)
  with the arm's a-priori and identified URDF models, from the FloBaRoID project (LGPL-3.0).
* :func:`list_datasets`: the data sets, one line each.

The data are not under dynval's MIT licence: each data set's ``DESCR`` and the README and licence
files beside its data (``dynval/datasets/data/<name>/``) say where they come from and under which
licence they are distributed.

Examples
--------
>>> from dynval.datasets import list_datasets, load_kuka_lwr4
>>> sorted(list_datasets())
['kuka_lwr4']
>>> run = load_kuka_lwr4(1)
>>> run.q.shape, run.tau.shape, run.sample_rate
((5027, 7), (5027, 7), 200.0)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np
from numpy.typing import NDArray

from ..checks._validation import is_integer, parameter_error

__all__ = ["KukaLWR4Run", "load_kuka_lwr4", "list_datasets"]

DATA_DIR = Path(__file__).resolve().parent / "data"
"""The directory of the packaged data files, one subdirectory per data set."""

_KUKA_DIR = DATA_DIR / "kuka_lwr4"
_KUKA_RUNS = (1, 2, 3)
_KUKA_JOINTS = tuple(f"lwr_{j}_joint" for j in range(7))
# The upstream files' names of the five arrays kept, and the names dynval gives them.
_KUKA_KEYS = {"positions": "q", "velocities": "dq", "accelerations": "ddq", "torques": "tau"}
_KUKA_UNITS = MappingProxyType({"time": "s", "q": "rad", "dq": "rad/s", "ddq": "rad/s²", "tau": "N·m",
                                "sample_rate": "Hz", "start_time": "s (Unix time)"})
_KUKA_RUN_TEXT = {
    1: "run 1 of 3: the commanded trajectory that run 2 repeats",
    2: "run 2 of 3: repeats run 1's commanded trajectory",
    3: "run 3 of 3: a commanded trajectory different from runs 1 and 2",
}

KUKA_LWR4_DESCR = """\
KUKA LWR4+ measurements (FloBaRoID)
-----------------------------------
Three runs logged on a KUKA LWR4+ arm (7 revolute joints, lwr_0_joint to lwr_6_joint) by the
FloBaRoID project (Stefan Bethge, Istituto Italiano di Tecnologia), https://github.com/kjyv/FloBaRoID.

Licence: GNU Lesser General Public License, version 3 (LGPL-3.0), the upstream project's licence,
which covers its data (there is no separate data licence); not dynval's MIT licence. The licence
texts (LICENSE.md, GPL-3.0.txt) and a README naming the upstream commits are in the data directory,
dynval/datasets/data/kuka_lwr4/.

Runs: measurements_1.npz, measurements_2.npz and measurements_3.npz of upstream commit e6c077ea5c09
(2016-04-11). Runs 1 and 2 follow the same commanded trajectory (run 2 repeats run 1); run 3 follows
a different one. Each run has 5027 samples, about 25.13 s at 200 Hz (the logged time stamps are 5.0
ms apart on average, between 3.2 and 6.8 ms).

Signals: time (s, from the run's first sample; start_time is its Unix time), joint positions q
(rad), velocities dq (rad/s), accelerations ddq (rad/s²) and measured joint torques tau (N·m),
bit for bit the upstream arrays. The velocities and accelerations are the logged ones, filtered and
derived by FloBaRoID's excite.py with a zero-phase low-pass filter ("without time shift"); they are
not differentiated here. The commanded trajectory of the upstream files is not included.

Models (upstream commit 9c0680445e87): urdf is kuka_lwr4.urdf, the a-priori (CAD) model;
urdf_identified is kuka_lwr4_identified.urdf, the model FloBaRoID identified, with per-joint
viscous and Coulomb friction in its <dynamics> tags (the Coulomb values negative on lwr_3_joint to
lwr_6_joint) and without the torque offsets FloBaRoID also identifies. The meshes they refer to are
not included; the dynamics do not need them. dynval.robots.URDFModel reads both (pip install pin).
mjcf is kuka_lwr4.xml, an MJCF of the a-priori model for MuJoCo (written by dynval from kuka_lwr4.urdf,
so under the same LGPL-3.0), with joint armature, damping and frictionloss identified on run 1;
dynval.mjcf.MJCFModel reads it (pip install mujoco).
"""


@dataclass(frozen=True, repr=False)
class KukaLWR4Run:
    """One logged run of the KUKA LWR4+ data set (see :func:`load_kuka_lwr4`).

    Attributes
    ----------
    run : int
        1, 2 or 3.
    time : ndarray, shape (N,)
        Seconds from the run's first sample (N = 5027).
    q, dq, ddq : ndarray, shape (N, 7)
        Joint positions (rad), velocities (rad/s) and accelerations (rad/s²), as logged.
    tau : ndarray, shape (N, 7)
        Measured joint torques (N·m).
    joint_names : tuple of str
        ``lwr_0_joint`` ... ``lwr_6_joint``, the columns' joints (the URDFs' names).
    units : mapping
        Unit of each signal and number, by attribute name (read-only).
    sample_rate : float
        200.0 Hz, the nominal rate (the mean step of the time stamps is within 0.003 % of 5 ms).
    start_time : float
        Unix time of the first sample, in seconds.
    description : str
        One line: the run and its trajectory.
    urdf, urdf_identified : pathlib.Path
        The a-priori (CAD) model and the model identified by FloBaRoID.
    mjcf : pathlib.Path
        ``kuka_lwr4.xml``: the a-priori model as a MuJoCo MJCF, with joint ``armature``, ``damping``
        and ``frictionloss`` identified on run 1 (:class:`dynval.mjcf.MJCFModel`; contract §11).
    license : str
        ``"LGPL-3.0"``, the data's licence.
    DESCR : str
        Source, licence, signals and how the velocities and accelerations were obtained.

    Every array is read-only; copy it (``run.tau.copy()``) to change it.
    """

    run: int
    time: NDArray[np.float64]
    q: NDArray[np.float64]
    dq: NDArray[np.float64]
    ddq: NDArray[np.float64]
    tau: NDArray[np.float64]
    joint_names: tuple[str, ...]
    units: Mapping[str, str]
    sample_rate: float
    start_time: float
    description: str
    urdf: Path
    urdf_identified: Path
    mjcf: Path
    license: str = "LGPL-3.0"

    @property
    def DESCR(self) -> str:  # sklearn's name for a data set's description
        """Source, licence, signals and how the velocities and accelerations were obtained."""
        return KUKA_LWR4_DESCR

    @property
    def n_samples(self) -> int:
        """Number of samples N."""
        return int(self.time.shape[0])

    def __repr__(self) -> str:
        return (f"KukaLWR4Run(run={self.run}, n_samples={self.n_samples}, joints={len(self.joint_names)}, "
                f"sample_rate={self.sample_rate}, description={self.description!r})")


def _read_only(a: NDArray[np.float64]) -> NDArray[np.float64]:
    a.flags.writeable = False
    return a


def load_kuka_lwr4(run: int = 1) -> KukaLWR4Run:
    """Load one of the three logged runs of a KUKA LWR4+ (FloBaRoID, LGPL-3.0).

    Parameters
    ----------
    run : {1, 2, 3}, default 1
        The run. Runs 1 and 2 follow the same commanded trajectory, run 3 a different one: identify
        on run 1 and validate on run 3 for a prediction of new motion (validating on run 2 measures
        the fit to a repeat).

    Returns
    -------
    KukaLWR4Run
        ``time`` (N,), ``q``, ``dq``, ``ddq``, ``tau`` (N, 7) as read-only float64 arrays, with
        N = 5027 samples at ``sample_rate`` = 200 Hz, ``joint_names``, ``units``, the paths ``urdf``,
        ``urdf_identified`` and ``mjcf``, and ``DESCR`` (source, licence and how the accelerations were obtained).

    Raises
    ------
    dynval.InvalidParameter
        ``run`` is not one of 1, 2, 3 (a ``ValueError``).

    Examples
    --------
    >>> from dynval.datasets import load_kuka_lwr4
    >>> r = load_kuka_lwr4(3)
    >>> r.tau.shape, r.sample_rate, r.joint_names[0], r.units["tau"]
    ((5027, 7), 200.0, 'lwr_0_joint', 'N·m')
    >>> r.urdf.name, r.license
    ('kuka_lwr4.urdf', 'LGPL-3.0')

    There are only three runs; any other value is refused with the valid ones:

    >>> load_kuka_lwr4(4)
    Traceback (most recent call last):
        ...
    dynval.checks._errors.InvalidParameter: run must be one of 1, 2, 3, got 4
    """
    if not is_integer(run) or int(run) not in _KUKA_RUNS:
        raise parameter_error("run", "one of " + ", ".join(map(str, _KUKA_RUNS)), run)
    k = int(run)
    with np.load(_KUKA_DIR / f"measurements_{k}.npz") as f:
        times = np.asarray(f["times"], dtype=np.float64)
        signals = {name: _read_only(np.asarray(f[key], dtype=np.float64)) for key, name in _KUKA_KEYS.items()}
    start = float(times[0])
    return KukaLWR4Run(
        run=k,
        time=_read_only(times - times[0]),
        q=signals["q"],
        dq=signals["dq"],
        ddq=signals["ddq"],
        tau=signals["tau"],
        joint_names=_KUKA_JOINTS,
        units=_KUKA_UNITS,
        sample_rate=200.0,
        start_time=start,
        description=f"KUKA LWR4+ (FloBaRoID, LGPL-3.0), {_KUKA_RUN_TEXT[k]}; "
                    f"{times.shape[0]} samples at 200 Hz",
        urdf=_KUKA_DIR / "kuka_lwr4.urdf",
        urdf_identified=_KUKA_DIR / "kuka_lwr4_identified.urdf",
        mjcf=_KUKA_DIR / "kuka_lwr4.xml",
    )


def list_datasets() -> dict[str, str]:
    """The packaged data sets: name → one line (loader, content, licence).

    Returns
    -------
    dict of str to str

    Examples
    --------
    >>> from dynval.datasets import list_datasets
    >>> list_datasets()["kuka_lwr4"].split(":")[0]
    'load_kuka_lwr4(run=1|2|3)'
    """
    return {"kuka_lwr4": "load_kuka_lwr4(run=1|2|3): KUKA LWR4+, 7 joints, 3 runs of 5027 samples at 200 Hz, "
                         "CAD and identified URDF (FloBaRoID, LGPL-3.0)"}
