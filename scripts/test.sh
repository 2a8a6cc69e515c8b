#!/usr/bin/env bash
# The README's test command: set up everything on a fresh machine, lint, run the test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
set +u
. scripts/env.sh
set -u
# One BLAS thread: the models are small (eigendecompositions of ~178x178 blocks); threaded BLAS on a
# 2-core machine shared with the simulation was measured 10-100x slower (docs/solver.md).
export OPENBLAS_NUM_THREADS=${OPENBLAS_NUM_THREADS:-1}
echo "[test] ruff check"
ruff check .
ruff format --check . >/dev/null || { echo "[test] ruff format would change files:"; ruff format --check .; exit 1; }
# Two stages, both always run: the unit tests (-m 'not acceptance'), then the acceptance tests
# (-m acceptance: record-level calibrations, 35-140 s each at load; pyproject.toml). Extra arguments go to
# both stages' pytest (after the stage's -m, so a -m of yours replaces it); a stage in which they select
# no test (pytest exit status 5) counts as passed unless both select none. TEST_STAGES=unit or TEST_STAGES=acceptance runs one.
# Two workers (pytest-xdist), each test file whole on one worker so that its module fixtures are
# computed once, and the files that read the session's shared calibrations together on one
# (test/conftest.py, pytest_xdist_make_scheduler): the suite is single-threaded CPU work, mostly
# calibrations (docs/history/calibration_sessions.md Secs. 8.39, 8.72). PYTEST_WORKERS=0 runs it in one process.
workers=${PYTEST_WORKERS:-2}
xdist=()
if [ "$workers" != 0 ] && python -c "import xdist" 2>/dev/null; then
  xdist=(-n "$workers" --dist loadfile)
fi
status=0
selected=0
for stage in ${TEST_STAGES:-unit acceptance}; do
  case "$stage" in
    unit) select="not acceptance" ;;
    acceptance) select="acceptance" ;;
    *) echo "[test] unknown stage '$stage' (unit, acceptance)"; exit 2 ;;
  esac
  echo "[test] pytest: $stage tests (-m '$select')"
  start=$(date +%s)
  rc=0
  python -m pytest -q "${xdist[@]}" -m "$select" "$@" || rc=$?
  echo "[test] $stage stage: $(($(date +%s) - start)) s wall, pytest exit status $rc"
  if [ "$rc" != 5 ]; then selected=1; fi
  if [ "$rc" != 0 ] && [ "$rc" != 5 ]; then status=$rc; fi
done
if [ "$status" = 0 ] && [ "$selected" = 0 ]; then status=5; fi
exit "$status"
