#!/usr/bin/env bash
# Install the dynval C++ package to a temporary prefix (no Python involved), build the example
# against it with find_package(dynval), and run it. Used by CI.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
generator=()
if command -v ninja > /dev/null; then generator=(-G Ninja); fi
# CMAKE_PREFIX_PATH from the environment (e.g. the cmeel-eigen prefix) reaches both configures.
cmake -S "$root" -B "$work/build" "${generator[@]}" -DDYNVAL_PYTHON=OFF -DDYNVAL_TESTS=OFF > "$work/configure.log"
cmake --install "$work/build" --prefix "$work/prefix" > "$work/install.log"
cmake -S "$root/cpp/examples" -B "$work/example" "${generator[@]}" -DCMAKE_PREFIX_PATH="$work/prefix" \
  > "$work/example-configure.log"
cmake --build "$work/example" > "$work/example-build.log"
"$work/example/validate_example"
