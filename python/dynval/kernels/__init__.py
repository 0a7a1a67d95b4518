"""The backends: the numpy/scipy reference kernels, the compiled core's binding, BLAS threads."""
