#!/usr/bin/env bash
# The streamed tables of docs/online.md: every test recording of SDD (in metres) and of the five
# ETH/UCY scenes through the shipped default, loop off and on, with 12 and with 2 forecasts per
# track awaiting their truth. Seconds on one core; the loop's settings were chosen on validation
# (scripts/online-sweep.py), the test recordings are only reported.
#   scripts/online-runs.sh [OUT_DIR]   (default target/online; then scripts/online-summary.py OUT_DIR)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-target/online}
BIN=${GPECNET:-target/release/gpecnet}
[ -x "$BIN" ] || cargo build --release -p gpecnet-trainer --bin gpecnet
mkdir -p "$OUT"
for p in 12 2; do
    for ds in sdd-m eth_ucy:eth eth_ucy:hotel eth_ucy:univ eth_ucy:zara1 eth_ucy:zara2; do
        "$BIN" stream --blob weights/sdd-m-lp-qe.gpec --dataset "$ds" --pending "$p" --json \
            >"$OUT/${ds/:/-}-p$p.json"
    done
done
"$BIN" stream --blob weights/sdd-m-lp-qe.gpec --dataset eth_ucy:univ --pending 12 \
    --plot "$OUT/online-coverage-univ.svg" >/dev/null
python3 scripts/online-summary.py "$OUT"
