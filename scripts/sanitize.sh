#!/usr/bin/env bash
# Builds dynval._core with AddressSanitizer + UndefinedBehaviorSanitizer and runs the fuzz suites
# against it: tests/test_fuzz.py (every public function on both backends, every _core kernel
# against the reference), tests/test_fuzz_readers.py (mutated CSV, .npy, .npz, HDF5 and Parquet
# files read whole and in blocks: an array or a FileInputError, never another exception or a hang),
# tests/test_fuzz_time.py (time stamps, bandwidths and joint positions q on validate and the
# streamed accumulator: a report or an InputError) and tests/test_fuzz_surfaces.py (fleet manifests
# and settings, physical_consistency on vectors and URDF files, any names on the HTML pages and
# figures: a result or an InputError).
# Any sanitizer report aborts the run with a non-zero exit.
#
#   scripts/sanitize.sh            bounded run for CI: 40 examples per test (about 2,600 in all)
#   scripts/sanitize.sh 1800 --hypothesis-show-statistics
#                                  the full run recorded in README.md (over 100,000 examples);
#                                  arguments after the count go to pytest
#
# The module is built in build/sanitize and imported from a staged copy of python/dynval, with
# site processing off (python -S) so that an editable install of dynval cannot shadow it.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
EXAMPLES=${1:-40}
shift || true
build=build/sanitize
flags="-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer -g"

pybind11_dir=$("$PY" -m pybind11 --cmakedir)
prefix=$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDYNVAL_PYTHON=ON -DDYNVAL_TESTS=OFF \
  -DPython_EXECUTABLE="$(command -v "$PY")" -Dpybind11_DIR="$pybind11_dir" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_MODULE_LINKER_FLAGS="-fsanitize=address,undefined" >/dev/null
cmake --build "$build" -j2 --target _core

stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
cp -r python/dynval "$stage/dynval"
rm -f "$stage"/dynval/_core*.so
cp "$(find "$build" -name '_core*.so' | head -n1)" "$stage/dynval/"

# The sanitizer runtimes must be loaded before the interpreter's own allocations.
preload="$(${CXX:-c++} -print-file-name=libasan.so) $(${CXX:-c++} -print-file-name=libubsan.so)"
# The interpreter's package directories, and those its .pth files add (python -S skips them): pinocchio's
# cmeel prefix, which physical_consistency needs.
site=$("$PY" -c 'import sys, sysconfig; p = sysconfig.get_paths()
print(":".join([p["purelib"], p["platlib"]] + [d for d in sys.path if "cmeel.prefix" in d]))')
log=$(mktemp)
set +e
LD_PRELOAD="$preload" \
  ASAN_OPTIONS=detect_leaks=0:abort_on_error=1:halt_on_error=1 \
  UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
  ARROW_DEFAULT_MEMORY_POOL=system \
  DYNVAL_FUZZ_EXAMPLES="$EXAMPLES" PYTHONPATH="$stage:$site" \
  "$PY" -S -m pytest -q -p no:cacheprovider tests/test_fuzz.py tests/test_fuzz_readers.py \
  tests/test_fuzz_time.py tests/test_fuzz_surfaces.py "$@" 2>&1 | tee "$log"
status=${PIPESTATUS[0]}
set -e
if grep -qE "ERROR: AddressSanitizer|runtime error:|UndefinedBehaviorSanitizer" "$log"; then
  echo "sanitize: sanitizer findings (see above)" >&2
  exit 1
fi
[ "$status" = 0 ] || { echo "sanitize: the fuzz suite failed" >&2; exit "$status"; }
echo "sanitize: no sanitizer findings ($EXAMPLES examples per fuzz test)"
