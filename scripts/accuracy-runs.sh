#!/usr/bin/env bash
# The accuracy study's training runs (docs/accuracy.md): every (config, heading, seed) as a
# resumable run under runs/acc/, JOBS at a time (default 2). Re-running the script resumes
# unfinished runs and skips finished ones. Usage:
#   scripts/accuracy-runs.sh CONFIG NAME "HEADINGS" "SEEDS" [EPOCHS]
# e.g. scripts/accuracy-runs.sh host-trainer/configs/sdd-tiny-point.toml tiny "0 1 3" "1 2 3"
# EXTRA="--mirror" adds flags to new runs.
set -euo pipefail
cd "$(dirname "$0")/.."
cfg=$1 name=$2 headings=$3 seeds=$4 epochs=${5:-}
jobs=${JOBS:-2}
bin=target/release/gpecnet
cargo build --release -q -p gpecnet-trainer
run_one() {
  local h=$1 s=$2 out=runs/acc/$name-h$1-s$2
  local ep=()
  [ -n "$epochs" ] && ep=(--epochs "$epochs")
  if [ -f "$out/checkpoint.bin" ]; then
    "$bin" train --resume --out "$out" --quiet "${ep[@]}" >"$out.log" 2>&1 || { echo "FAILED $out (see $out.log)"; return 1; }
  else
    mkdir -p runs/acc
    "$bin" train --config "$cfg" --seed "$s" --heading-steps "$h" --out "$out" --quiet ${EXTRA:-} "${ep[@]}" >"$out.log" 2>&1 || { echo "FAILED $out (see $out.log)"; return 1; }
  fi
  echo "done $out: $(tail -1 "$out.log")"
}
for h in $headings; do for s in $seeds; do
  while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do sleep 2; done
  run_one "$h" "$s" &
done; done
wait
