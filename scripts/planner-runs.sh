#!/usr/bin/env bash
# The endpoint-probability fits of docs/planner.md: one per 8-wide proposal seed
# (runs/latents/h8-s<seed>, made by scripts/latents-runs.sh), on the frozen sdd-m-tiny CVAE.
# Each takes about 6 s on one core; a finished fit is skipped. Validation only.
set -euo pipefail
cd "$(dirname "$0")/.."
GPECNET=${GPECNET:-target/release/gpecnet}
DATA=${DATA:-../shared/data}
for s in 0 1 2; do
  out=runs/score/h8-s$s
  [ -f "$out/score.json" ] && continue
  "$GPECNET" score --blob weights/sdd-m-tiny.gpec --proposal runs/latents/h8-s$s/proposal.json \
    --data "$DATA" --out "$out"
done
python3 scripts/planner-summary.py
