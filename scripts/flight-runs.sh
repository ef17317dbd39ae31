#!/usr/bin/env bash
# Synthetic flight (docs/camera.md, "Synthetic flight"): the shipped default streamed through
# `gpecnet stream` on the test recordings of the five ETH/UCY scenes and of SDD in metres,
# clean and seen through the simulated drone (`--flight`: 30 m ± 5 m up on a 20 m orbit, a 90°
# yaw in 2 s every 30 s, 5 % misses), with and without the filter (its σ per detection from the
# measurement model), at the issue's noise (2 px, 0.5° drawn afresh every frame), at 0.5°
# drifting with a 5 s correlation time, at 0.1°, and with pixel noise alone. The loop-off rows
# are the model's; scripts/flight-summary.py tabulates them.
#
# Usage: [BIN=path/to/gpecnet] [BLOB=weights/sdd-m-lp-qe.gpec] [OUT=target/flight]
#        scripts/flight-runs.sh
set -euo pipefail
cd "$(dirname "$0")/.."
out=${OUT:-target/flight}
blob=${BLOB:-weights/sdd-m-lp-qe.gpec}
if [ -z "${BIN:-}" ]; then
  cargo build --release -q -p gpecnet-trainer --bin gpecnet
  BIN=target/release/gpecnet
fi
mkdir -p "$out"
run() { # name, dataset, extra args...
  local name=$1 ds=$2
  shift 2
  local f="$out/$name.json"
  [ -f "$f" ] && return 0
  "$BIN" stream --blob "$blob" --dataset "$ds" --split test "$@" --json >"$f.tmp" && mv "$f.tmp" "$f"
}
for ds in eth_ucy:eth eth_ucy:hotel eth_ucy:univ eth_ucy:zara1 eth_ucy:zara2 sdd-m; do
  sc=${ds#eth_ucy:}
  run "$sc-clean" "$ds"
  run "$sc-flight" "$ds" --flight
  run "$sc-flight-filter" "$ds" --flight --filter
  run "$sc-flight-drift5-filter" "$ds" --flight --attitude-correlation-s 5 --filter
  run "$sc-flight-att01-filter" "$ds" --flight --attitude-noise-deg 0.1 --filter
  run "$sc-flight-px-filter" "$ds" --flight --attitude-noise-deg 0 --filter
  echo "done $sc"
done
