#!/usr/bin/env bash
# Mutation testing of the decision code with mutmut (3.x): which changes to the findings' rules,
# compare's ranking and verdict, and the statistics under them does the test selection let through?
#
#   bash scripts/mutation.sh                      # report/_findings.py, comparison/_compare.py and statistics/_stats.py
#   bash scripts/mutation.sh comparison/_compare.py   # one module (paths under python/dynval/)
#   MUTATION_TIME_LIMIT=900 MUTATION_JOBS=1 bash scripts/mutation.sh comparison/_compare.py
#
# It never touches the working tree: python/dynval is copied (uncommitted changes included) into a
# work directory laid out as mutmut expects (src/dynval, tests/, pyproject.toml with a [tool.mutmut]
# section appended), the compiled dynval._core of the installed package is copied beside it, and
# mutmut runs there under `python -S` with the interpreter's site-packages on PYTHONPATH, so that the
# editable install's import hook cannot send `import dynval` back to the working tree (`exit`, which
# mutmut calls on its error paths and only `site` defines, is put back). At the end it
# prints the count per status, the kill rate (killed / (killed + survived + timeout + suspicious)),
# every surviving mutant with its diff, and the work directory, where `mutmut show NAME`, `mutmut
# results` and `mutmut browse` still work (run them there with the same PYTHONPATH and `python -S`;
# the script prints the command). A second run with the same MUTATION_WORK only re-tests what changed.
#
# Environment:
#   MUTATION_TESTS       pytest arguments of the test selection (default: the fast tests that pin the
#                        decisions: tests/test_decisions.py tests/test_finding_records.py tests/test_findings.py
#                        tests/test_compare.py
#                        tests/test_text.py tests/test_regressor_acf.py tests/test_stats_reference.py).
#                        mutmut runs, for each mutant,
#                        only the tests of the selection that call the mutated function.
#   MUTATION_TIME_LIMIT  seconds; mutmut is interrupted then (SIGINT: it stops its workers and keeps
#                        every result so far) and the summary covers the mutants it reached.
#   MUTATION_JOBS        parallel mutant workers (default 2, the cores of the project's machines).
#   MUTATION_WORK        work directory (default: a new one under ${TMPDIR:-/tmp}); kept afterwards.
#   MUTATION_DIFFS       0 to list the survivors without their diffs (default 1).
#   MUTATION_MUTANTS     mutant names or globs to (re-)test only those, e.g.
#                        'dynval.comparison._compare.x__verdict__mutmut_*' (the verdict's mutants). mutmut tests
#                        the mutants with the fastest tests first, so a time limit leaves those of the
#                        functions with the slowest tests (compare, _verdict: the simulations of
#                        tests/test_compare.py) for last; name them to reach them.
#   PYTHON               interpreter with dynval's dependencies and pytest (default python3).
#   MUTATION_VENV        where mutmut is installed when the interpreter lacks it (default
#                        ~/.cache/dynval/mutmut-venv; a venv of the same interpreter, so the
#                        project's environment is left as it is). mutmut comes from PyPI (pip).
#
# mutmut 3 reads `source_paths` (formerly `paths_to_mutate`), `only_mutate` and
# `pytest_add_cli_args_test_selection` (formerly `tests_dir`) from pyproject.toml's [tool.mutmut]
# (setup.cfg's [mutmut] only when pyproject.toml has none); pytest is its only runner, and it names a
# mutant after its module path with a leading `src.` stripped: hence the src/ layout of the copy.
# A full campaign over the three modules runs for hours on two cores (mostly string mutants of the
# messages); use MUTATION_TIME_LIMIT or one module at a time.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
PY=${PYTHON:-python3}
JOBS=${MUTATION_JOBS:-2}
# compare with a candidate's parameters is pinned in test_physical_consistency.py; that file as a whole
# fails mutmut's clean run (one triangle-inequality case under its instrumentation), so only its
# compare test is in the selection.
TESTS=${MUTATION_TESTS:-tests/test_decisions.py tests/test_finding_records.py tests/test_findings.py tests/test_compare.py tests/test_text.py tests/test_regressor_acf.py tests/test_stats_reference.py tests/test_physical_consistency.py::test_compare_ranks_a_candidate_that_is_no_robot_after_a_sound_one}
MODULES=("$@")
[ ${#MODULES[@]} -gt 0 ] || MODULES=(report/_findings.py comparison/_compare.py statistics/_stats.py)
for mod in "${MODULES[@]}"; do
  [ -f "$ROOT/python/dynval/$mod" ] || { echo "mutation.sh: no module python/dynval/$mod" >&2; exit 2; }
done

# The interpreter's own site-packages (numpy, scipy, pytest, hypothesis, ...), read without -S.
SITE=$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
PLAT=$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["platlib"])')
PYPATH="$SITE"
[ "$PLAT" = "$SITE" ] || PYPATH="$PYPATH:$PLAT"
if ! "$PY" -c 'import mutmut, sys; sys.exit(int(mutmut.__version__.split(".")[0]) < 3)' 2>/dev/null; then
  VENV=${MUTATION_VENV:-$HOME/.cache/dynval/mutmut-venv}
  if [ ! -x "$VENV/bin/python" ]; then
    echo "== installing mutmut (PyPI) into $VENV"
    "$PY" -m venv "$VENV"
  fi
  "$VENV/bin/python" -c 'import mutmut' 2>/dev/null || "$VENV/bin/python" -m pip install -q "mutmut>=3.8,<4"
  PYPATH="$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])'):$PYPATH"
fi

WORK=${MUTATION_WORK:-$(mktemp -d "${TMPDIR:-/tmp}/dynval-mutation.XXXXXX")}
mkdir -p "$WORK/src/dynval" "$WORK/tests"
echo "== work directory $WORK"
# The package as it is in the working tree (uncommitted changes included), without caches.
(cd "$ROOT/python/dynval" && tar --exclude=__pycache__ --exclude='*.so' -cf - .) | tar -xf - -C "$WORK/src/dynval"
(cd "$ROOT/tests" && tar --exclude=__pycache__ -cf - .) | tar -xf - -C "$WORK/tests"
# The compiled core of the installed package (an editable install keeps it in site-packages); without
# one the package runs on its python backend.
CORE=$("$PY" -c 'import dynval._core as c; print(c.__file__)' 2>/dev/null || true)
if [ -n "$CORE" ] && [ -f "$CORE" ]; then cp "$CORE" "$WORK/src/dynval/"; else echo "   (no compiled dynval._core: python backend only)"; fi

# pyproject.toml: the project's pytest settings, and the mutmut section (rewritten on every run).
quote() { for x in "$@"; do printf '"%s", ' "$x"; done; }
only=()
for mod in "${MODULES[@]}"; do only+=("src/dynval/$mod"); done
read -r -a selection <<< "$TESTS"
{
  sed '/^\[tool\.mutmut\]/,$d' "$ROOT/pyproject.toml"
  echo
  echo "[tool.mutmut]"
  echo 'source_paths = ["src/dynval"]'
  echo "only_mutate = [$(quote "${only[@]}")]"
  echo "pytest_add_cli_args_test_selection = [$(quote "${selection[@]}")]"
  echo 'pytest_add_cli_args = ["-p", "no:cacheprovider"]'
  echo 'use_git_change_detection = false'
} > "$WORK/pyproject.toml"

MUTMUT=(env PYTHONPATH="$PYPATH" PYTHONDONTWRITEBYTECODE=1 "$PY" -S -c
        'import builtins, sys; builtins.exit = sys.exit; from mutmut.__main__ import cli; sys.argv[0] = "mutmut"; sys.exit(cli())')
cd "$WORK"
# The copy, not the working tree, must be what the tests import.
got=$(PYTHONPATH="$WORK/src:$PYPATH" "$PY" -S -c 'import dynval; print(dynval.__file__)')
[ "$got" = "$WORK/src/dynval/__init__.py" ] || { echo "mutation.sh: dynval imports from $got, not the copy" >&2; exit 1; }

echo "== mutmut run (${MODULES[*]}; tests: $TESTS; $JOBS workers${MUTATION_TIME_LIMIT:+; at most ${MUTATION_TIME_LIMIT} s})"
read -r -a names <<< "${MUTATION_MUTANTS:-}"
limit=()
[ -z "${MUTATION_TIME_LIMIT:-}" ] || limit=(timeout --signal=INT --kill-after=120 "$MUTATION_TIME_LIMIT")
# mutmut redraws one progress line (carriage returns): keep one line in 50 of it, and the last.
set +e
"${limit[@]}" "${MUTMUT[@]}" run --max-children "$JOBS" "${names[@]}" 2>&1 | tr '\r' '\n' | awk '
  $2 ~ /^[0-9]+\/[0-9]+$/ { last = $0; if (++n % 50 == 0) print; next }
  { if (last != "") { print last; last = "" } print }
  END { if (last != "") print last }'
status=${PIPESTATUS[0]}
set -e
# 124: the time limit interrupted the run (the results so far are kept); anything else is a failure
# of mutmut itself and its output above says which: most often "Failed to run clean test", a test of
# the selection that fails on the unmutated copy (mutation testing needs a green selection).
if [ "$status" -ne 0 ] && [ "$status" -ne 124 ]; then
  echo "mutation.sh: mutmut run exited with $status" >&2
  exit "$status"
fi

echo
echo "== summary"
env PYTHONPATH="$PYPATH" "$PY" -S - "${MUTATION_DIFFS:-1}" <<'EOF'
import collections
import sys

from mutmut.mutation.diff_apply import get_diff_for_mutant
from mutmut.utils.file_utils import walk_mutatable_files
from mutmut.mutation.data import SourceFileMutationData
from mutmut.stats import status_by_exit_code

diffs = sys.argv[1] != "0"
count = collections.Counter()
per_file = {}
survivors = []
for path in walk_mutatable_files():
    data = SourceFileMutationData(path=path)
    data.load()
    c = collections.Counter(status_by_exit_code[code] for code in data.exit_code_by_key.values())
    per_file[str(path)] = c
    count.update(c)
    survivors += [(name, path) for name, code in data.exit_code_by_key.items()
                  if status_by_exit_code[code] == "survived"]


def rate(c):
    decided = c["killed"] + c["survived"] + c["timeout"] + c["suspicious"]
    return f"{100 * c['killed'] / decided:.1f} %" if decided else "n/a"


for path, c in per_file.items():
    print(f"{path}: {sum(c.values())} mutants, " + ", ".join(f"{k} {v}" for k, v in sorted(c.items()))
          + f"; kill rate {rate(c)}")
print(f"all: {sum(count.values())} mutants, " + ", ".join(f"{k} {v}" for k, v in sorted(count.items()))
      + f"; kill rate {rate(count)} (killed / killed + survived + timeout + suspicious)")
print(f"\n== {len(survivors)} surviving mutants")
for name, path in sorted(survivors, key=lambda s: s[0]):
    print(name)
    if diffs:
        print(get_diff_for_mutant(name, path=path).rstrip() + "\n")
EOF
echo
echo "work directory: $WORK"
echo "inspect there: cd $WORK && PYTHONPATH=$PYPATH $PY -S -c 'import builtins, sys; builtins.exit = sys.exit; from mutmut.__main__ import cli; sys.argv[0] = \"mutmut\"; sys.exit(cli())' show NAME"
