#!/usr/bin/env bash
# The README's test command: set up everything on a fresh machine, lint, run the test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
set +u
. scripts/env.sh
set -u
echo "[test] ruff check"
ruff check .
ruff format --check . >/dev/null || { echo "[test] ruff format would change files:"; ruff format --check .; exit 1; }
echo "[test] pytest"
python -m pytest -q "$@"
