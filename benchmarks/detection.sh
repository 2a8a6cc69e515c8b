#!/usr/bin/env bash
# The detection benchmark in one command: the fault-grid dataset (200 runs; resumable: run it again
# after an interruption), the tables of docs/detection.md and the monitor thresholds
# config/fault_thresholds.json (k = 6).
#   bash benchmarks/detection.sh [DATASET_DIR]      (default ./detection_ds; extra args: none)
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/env.sh
DS="${1:-detection_ds}"
python benchmarks/detection_sweep.py
gear-rotor-sim dataset benchmarks/detection_sweep.yaml --out "$DS"
python benchmarks/detection.py "$DS" --markdown docs/detection.md --json "$DS/detection.json" \
    --save-thresholds config/fault_thresholds.json
