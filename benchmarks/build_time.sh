#!/usr/bin/env bash
# Times the build of the Python module dynval._core, one job, from a clean build directory:
# once compiled as one translation unit (the default, DYNVAL_UNITY_BUILD=ON) and once one unit per
# binding family, with each unit's compile time. Prints the ratio measured in this run.
#
#   bash benchmarks/build_time.sh          (needs pybind11 and Eigen: pip install ".[test]" brings both)
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# A compiler launcher that logs each unit's wall time.
cat > "$work/timed" <<'EOF'
#!/bin/sh
start=$(date +%s%N)
"$@"
status=$?
for a in "$@"; do case "$a" in *.cpp|*.cxx) unit=$(basename "$a");; esac; done
echo "$(( ($(date +%s%N) - start) / 1000000 )) ${unit:-precompiled}" >> "$TIMES"
exit $status
EOF
chmod +x "$work/timed"

pybind11_dir=$("$PY" -m pybind11 --cmakedir)
prefix=$("$PY" -m cmeel cmake 2>/dev/null || "$PY" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')

build() {  # name, unity ON/OFF
  local dir="$work/$1" start
  export TIMES="$work/$1.times"
  : > "$TIMES"
  cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Release -DDYNVAL_PYTHON=ON -DDYNVAL_TESTS=OFF \
    -DDYNVAL_UNITY_BUILD="$2" -DPython_EXECUTABLE="$(command -v "$PY")" -Dpybind11_DIR="$pybind11_dir" \
    -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_CXX_COMPILER_LAUNCHER="$work/timed" >/dev/null
  start=$(date +%s%N)
  cmake --build "$dir" -j1 --target _core >/dev/null
  echo $(( ($(date +%s%N) - start) / 1000000 )) > "$work/$1.total"
}

echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg); $(nproc) cores; $(${CXX:-c++} --version | head -1)"
build per_family OFF
build unity ON
per=$(cat "$work/per_family.total")
one=$(cat "$work/unity.total")
echo
echo "one unit per binding family (DYNVAL_UNITY_BUILD=OFF), -j1: ${per} ms in all, compile and link"
sort -rn "$work/per_family.times" | awk '{printf "  %7d ms  %s\n", $1, $2}'
echo "one translation unit (DYNVAL_UNITY_BUILD=ON, the default), -j1: ${one} ms in all"
sort -rn "$work/unity.times" | awk '{printf "  %7d ms  %s\n", $1, $2}'
awk -v a="$per" -v b="$one" 'BEGIN { printf "ratio per-family / one unit: %.2f\n", a / b }'
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
