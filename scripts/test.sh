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
echo "[test] pytest"
# Two workers (pytest-xdist), each test file whole on one worker so that its module fixtures are
# computed once: the suite is single-threaded CPU work, mostly calibrations (docs/history/calibration_sessions.md
# Sec. 8.39). PYTEST_WORKERS=0 runs it in one process.
workers=${PYTEST_WORKERS:-2}
xdist=()
if [ "$workers" != 0 ] && python -c "import xdist" 2>/dev/null; then
  xdist=(-n "$workers" --dist loadfile)
fi
python -m pytest -q "${xdist[@]}" "$@"
