"""Reading data files: npy/npz/CSV, Parquet/HDF5, row sources for files larger than memory."""
