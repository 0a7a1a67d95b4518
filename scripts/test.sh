#!/usr/bin/env bash
# Sets up and runs every dynval test on a fresh machine:
#   1. Debian packages for the C++ tests (GoogleTest, Eigen) when run as root,
#   2. pip install ".[test]" (builds the C++ backend dynval._core),
#   3. the C++ core alone: ctest, then the example built against the installed CMake package,
#   4. the pure-Python build switch (-Cwheel.cmake=false) in a throwaway venv,
#   5. pytest: both backends against every golden vector, the protocol runner, the identities, the
#      findings and their calibration, the Java, MATLAB/Octave and Wolfram Language ports,
#   6. the fuzz suite against an AddressSanitizer + UndefinedBehaviorSanitizer build of the C++
#      backend (scripts/sanitize.sh, bounded: 40 examples per test, about 2,300 in all),
#   7. the conformance matrix of README.md against a fresh run of the ports it lists.
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
  export DYNVAL_REQUIRE_TOOLCHAINS=${DYNVAL_REQUIRE_TOOLCHAINS:-cc,java,octave,mathics}
fi

# Install from a clean copy of the tree: a development build of dynval/_core*.so copied into
# python/dynval (the fast C++ edit loop) would otherwise be swept into both wheels.
src=$(mktemp -d)
trap 'rm -rf "$src"' EXIT
tar --exclude='./build' --exclude='./.git' --exclude='*.so' --exclude='__pycache__' -cf - . | tar -xf - -C "$src"

step "pip install .[test]"
"$PY" -m pip install --quiet --disable-pip-version-check "$src[test]"
"$PY" -c "import dynval; print('dynval', dynval.__version__, dynval.backends())"

step "C++ core: ctest"
cmake -S . -B build/ctest -DCMAKE_BUILD_TYPE=Release -DDYNVAL_TESTS=ON -DDYNVAL_PYTHON=OFF >/dev/null
cmake --build build/ctest -j2
ctest --test-dir build/ctest --output-on-failure

step "C++ example against the installed CMake package"
bash cpp/examples/run_example.sh

step "pure-Python build (-Cwheel.cmake=false)"
venv=$(mktemp -d)/venv
"$PY" -m venv --system-site-packages "$venv"
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation -Cwheel.cmake=false "$src"
(cd "$venv" && "$venv/bin/python" -c "
import dynval
b = dynval.backends()
assert b['python']['available'] and not b['cpp']['available'], b
print('pure-Python build imports with backends', b)
")
rm -rf "$(dirname "$venv")"

step "pytest"
"$PY" -m pytest -q --durations=15 "$@"

step "sanitizers: the fuzz suite against dynval._core built with -fsanitize=address,undefined (bounded)"
PYTHON="$PY" bash scripts/sanitize.sh 40

step "conformance matrix (README.md against a fresh run of the ports it lists)"
# The Wolfram port is left out until it runs the corpus within the runner's limits (wolfram/README.md).
"$PY" -m dynval conform --matrix --ports python,cpp,java,matlab --check-readme
