// dynval: validation metrics for identified robot dynamic models (τ = Yπ + ε).
//
// Header-only C++17 core on Eigen; the same contract (docs/contract.md) as the Python package.
// Inputs are (N, m) Eigen expressions: samples are rows, joints are columns. Any expression
// works (Map with strides, Ref, blocks); nothing assumes contiguous storage.
#pragma once

#define DYNVAL_VERSION_STRING "0.1.0"
#define DYNVAL_CONTRACT_VERSION "1.0"

#include "accumulator.hpp"
#include "correlation.hpp"
#include "distributions.hpp"
#include "errors.hpp"
#include "information.hpp"
#include "lag_accumulator.hpp"
#include "metrics.hpp"
#include "options.hpp"
#include "segments.hpp"
