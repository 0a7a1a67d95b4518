"""Reading data files: npy/npz/CSV, Parquet/HDF5, row sources for files larger than memory, and the
joint states of a robot's own logs (ROS 2 and ROS 1 bags, MCAP files: :func:`read_joint_states`; a
vendor's CSV log by a declared column mapping: :func:`read_csv_log`)."""

from ._csvlog import MAPPINGS, CSVMapping, load_mapping, read_csv_log
from ._fileopen import FileInputError
from ._ros import EFFORT_UNITS, JOINT_STATE_TYPES, JointStateLog, read_joint_states

__all__ = ["FileInputError", "JointStateLog", "read_joint_states", "JOINT_STATE_TYPES", "EFFORT_UNITS", "CSVMapping",
           "MAPPINGS", "load_mapping", "read_csv_log"]
