#!/usr/bin/env bash
# Sets up and runs every dynval test on a fresh machine:
#   1. Debian packages for the C++ tests (GoogleTest, Eigen) when run as root,
#   2. pip install ".[test]" (builds the C++ backend dynval._core),
#   3. lint and types: ruff, and mypy (strict on the public modules; pyproject.toml says which),
#   4. the C++ core alone: ctest, then the example built against the installed CMake package,
#   5. the pure-Python build switch (--config-settings=wheel.cmake=false; pip >= 22.1 knows the long
#      form, -C only from 23.1) installed into a throwaway directory,
#   6. pytest: both backends against every golden vector, the protocol runner, the identities, the
#      findings and their calibration, the Java, MATLAB/Octave and Wolfram Language ports,
#   7. the fuzz suite against an AddressSanitizer + UndefinedBehaviorSanitizer build of the C++
#      backend (scripts/sanitize.sh, bounded: 40 examples per test, about 2,300 in all),
#   8. the conformance matrix of README.md against a fresh run of the ports it lists.
# Between 4 and 6 the documentation site is built with warnings as errors, its gallery run.
# As root (CI) the ports' toolchains are installed and required: a missing one fails the run.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
step() { printf '\n== %s\n' "$*"; }

export DYNVAL_REQUIRE_BACKENDS=${DYNVAL_REQUIRE_BACKENDS:-python,cpp}
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
  if ! dpkg -s libgtest-dev libeigen3-dev octave chromium >/dev/null 2>&1; then
    step "apt-get install libgtest-dev libeigen3-dev octave chromium"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      libgtest-dev libeigen3-dev octave chromium >/dev/null
  fi
  step "port toolchains"
  bash java/install-toolchain
  bash matlab/install-toolchain
  bash wolfram/install-toolchain
  export DYNVAL_REQUIRE_TOOLCHAINS=${DYNVAL_REQUIRE_TOOLCHAINS:-cc,java,octave,mathics,chromium}
else
  # Without root only what pip can put in the active environment is installed (Mathics3, in a venv
  # or a conda environment); a port whose toolchain is missing is skipped by its tests, and the
  # README's matrix, which lists every port, is then not checked (said at the end).
  step "port toolchains (no root: only what pip installs; the others must already be there)"
  missing_toolchains=()
  bash java/install-toolchain || missing_toolchains+=(java)
  bash matlab/install-toolchain || missing_toolchains+=(matlab)
  bash wolfram/install-toolchain || missing_toolchains+=(wolfram)
fi

# Install from a clean copy of the tree: a development build of dynval/_core*.so copied into
# python/dynval (the fast C++ edit loop) would otherwise be swept into both wheels.
src=$(mktemp -d)
trap 'rm -rf "$src"' EXIT
tar --exclude='./build' --exclude='./.git' --exclude='*.so' --exclude='__pycache__' -cf - . | tar -xf - -C "$src"

step "pip install .[test]"
n_units=$(ls cpp/bindings/*.cpp | wc -l)
echo "compiling the C++ extension dynval._core ($n_units translation units on pybind11 and Eigen) takes"
echo "a few minutes on 2 cores; pip prints nothing until it is done (add -v to see each step)."
build_start=$(date +%s)
"$PY" -m pip install --quiet --disable-pip-version-check "$src[test]"
echo "installed in $(( $(date +%s) - build_start )) s"
"$PY" -c "import dynval; print('dynval', dynval.__version__, dynval.backends())"

step "lint and types"
"$PY" -m ruff check python tests benchmarks golden examples docs
"$PY" -m mypy python/dynval

# Eigen from the cmeel-eigen wheel that the install above brought, for machines without Debian's.
cmeel_prefix=$("$PY" -m cmeel cmake 2>/dev/null || true)
export CMAKE_PREFIX_PATH="${cmeel_prefix}${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}"

step "C++ core: ctest"
mkdir -p build
if cmake -S . -B build/ctest -DCMAKE_BUILD_TYPE=Release -DDYNVAL_TESTS=ON -DDYNVAL_PYTHON=OFF \
    > build/ctest-configure.log 2>&1; then
  cmake --build build/ctest -j2
  ctest --test-dir build/ctest --output-on-failure
elif [ "$(id -u)" = 0 ] || [ -n "${CI:-}" ]; then
  cat build/ctest-configure.log
  exit 1
else
  # A developer without root and without GoogleTest still gets every other test.
  grep -m1 -A2 "CMake Error" build/ctest-configure.log || true
  printf 'SKIPPED: the C++ unit tests (ctest): CMake could not configure them (above; usually GoogleTest\n'
  printf '  is missing: Debian libgtest-dev, which this script installs when run as root). Going on.\n'
fi

step "C++ example against the installed CMake package"
bash cpp/examples/run_example.sh

step "pure-Python build (--config-settings=wheel.cmake=false)"
# Installed into a throwaway directory and imported with site processing off (python -S) and the
# active environment's own site-packages on the path: the check sees this interpreter's packages
# (a venv's, a conda environment's or the system's), and neither the installed dynval nor an
# editable install's import hook can stand in for the pure-Python one.
pure=$(mktemp -d)
"$PY" -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation --config-settings=wheel.cmake=false \
  --target "$pure" "$src"
site=$("$PY" -c 'import sysconfig; p = sysconfig.get_paths(); print(p["purelib"] + ":" + p["platlib"])')
(cd "$pure" && PYTHONPATH="$pure:$site" "$PY" -S -c "
import dynval
assert dynval.__file__.startswith('$pure'), dynval.__file__
b = dynval.backends()
assert b['python']['available'] and not b['cpp']['available'], b
print('pure-Python build imports with backends', b)
")
rm -rf "$pure"

step "documentation site: sphinx -W, every gallery example run (docs/_build/html)"
# tests/test_docs.py builds the text and checks every public name's page; here the whole site is
# built as a reader gets it, the gallery's examples run (a failing example or any warning fails).
MPLBACKEND=Agg "$PY" -m sphinx -W --keep-going -q -b html docs docs/_build/html
echo "built docs/_build/html/index.html"

step "pytest"
# The Wolfram port's whole corpus (about 8 minutes under Mathics3 with two port processes) is run once,
# by the conformance-matrix step below; its pytest test says so when it skips.
export DYNVAL_CORPUS_IN_MATRIX=wolfram
# On every core (pytest-xdist; the slow tests start first, tests/conftest.py): about half the time
# of one process on 2 cores. `bash scripts/test.sh -n 0` runs them in one process.
"$PY" -m pytest -q -n auto --durations=15 "$@"

step "sanitizers: the fuzz suite against dynval._core built with -fsanitize=address,undefined (bounded)"
PYTHON="$PY" bash scripts/sanitize.sh 40

step "conformance matrix (README.md against a fresh run of the ports it lists)"
# Two port processes per port: Mathics3 takes about a second per case. A busy machine can take a
# Mathics3 case past the default 30 s per case: 120 s here (and 300 s to start a port); the run
# prints a progress line a minute for a long port, and every failed case with expected and got.
if [ -n "${missing_toolchains+set}" ] && [ "${#missing_toolchains[@]}" -gt 0 ]; then
  printf 'SKIPPED: the README matrix check: it lists every port, and the toolchains of %s are missing\n' \
    "${missing_toolchains[*]}"
  printf '  (above; run as root to have them installed). The other steps passed.\n'
  exit 0
fi
"$PY" -m dynval conform --matrix --ports python,cpp,java,matlab,wolfram --jobs 2 --timeout 120 \
  --startup-timeout 300 --check-readme
