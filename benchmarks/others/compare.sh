#!/usr/bin/env bash
# Measure VMAS and flatland_ma in turn, ROUNDS times (the machine's speed drifts: compare
# medians of interleaved runs). VMAS runs in its own environment (README.md here).
# Usage: VMAS_PYTHON=/path/to/vmas-venv/bin/python benchmarks/others/compare.sh OUT_DIR
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
out="${1:-compare}"
mkdir -p "$out"
for round in $(seq "${ROUNDS:-2}"); do
	"${VMAS_PYTHON:?set VMAS_PYTHON}" "$here/vmas_lidar.py" --seconds "${SECONDS_PER_ROW:-2}" >>"$out/vmas.jsonl"
	"${FLATLAND_PYTHON:-python}" "$here/flatland_rows.py" --seconds "${SECONDS_PER_ROW:-2}" >>"$out/flatland.jsonl"
done
