#!/usr/bin/env bash
# The README's main command: set up (idempotent), start the simulator node with recording, steer it
# with speed and temperature setpoints from another process, and print what was published.
#   bash scripts/demo.sh [--real-time-factor 2.0] [--speed-rpm 5000] [--temperature-c 125] [--out out/demo]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
set +u
. scripts/env.sh
set -u
# One BLAS thread: the models are small (eigendecompositions of ~178x178 blocks); threaded BLAS on a
# 2-core machine shared with the simulation was measured 10-100x slower (docs/solver.md).
export OPENBLAS_NUM_THREADS=${OPENBLAS_NUM_THREADS:-1}
exec python -m gear_rotor_sim.ros.demo "$@"
