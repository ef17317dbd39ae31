#!/usr/bin/env bash
# The training runs of docs/generalisation.md, each a resumable run folder under $RUNS
# (default runs/gen), JOBS at a time (default 2). Re-running resumes unfinished runs and skips
# finished ones. BIN overrides the trainer binary (default: build target/release/gpecnet).
#   sdd-m-s<seed>        SDD in metres (host-trainer/configs/sdd-m-tiny.toml), 600 epochs
#   sdd-m-syn6-s<seed>   the same + 6 % synthetic trajectories (the paper's augmentation), the
#                        pool converted at 0.0377 m/px
#   eth-<scene>-s<seed>  ETH/UCY leave-one-scene-out (configs/ethucy-tiny.toml), 150 epochs
#   sdd-m-mirror-s<seed> sdd-m + reflection augmentation (--mirror)
#   sdd-m-speed-s<seed>  sdd-m + speed augmentation (configs/sdd-m-tiny-speed.toml)
# Usage: scripts/generalisation-runs.sh [GROUP...]   (groups: sdd-m syn eth levers; default all)
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${RUNS:-runs/gen}
jobs=${JOBS:-2}
seeds=${SEEDS:-"1 2 3"}
if [ -z "${BIN:-}" ]; then
  cargo build --release -q -p gpecnet-trainer
  BIN=target/release/gpecnet
fi
mkdir -p "$runs"
groups=${*:-"sdd-m syn eth levers"}
run_one() { # name, epochs, new-run flags...
  local out=$runs/$1 epochs=$2
  shift 2
  if [ -f "$out/checkpoint.bin" ]; then
    "$BIN" train --resume --out "$out" --quiet --epochs "$epochs" >>"$out.log" 2>&1 || { echo "FAILED $out (see $out.log)"; return 1; }
  else
    "$BIN" train "$@" --out "$out" --quiet --epochs "$epochs" >"$out.log" 2>&1 || { echo "FAILED $out (see $out.log)"; return 1; }
  fi
  echo "done $out: $(tail -1 "$out.log")"
}
wait_slot() { while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do sleep 2; done; }
pool=$runs/pool/pool.csv
for g in $groups; do
  case $g in
    sdd-m) for s in $seeds; do wait_slot
        run_one "sdd-m-s$s" 600 --config host-trainer/configs/sdd-m-tiny.toml --seed "$s" & done ;;
    syn)
      if [ ! -f "$pool" ]; then "$BIN" synth --n 1000 --seed 1 --out "$pool" >"$runs/pool.log" 2>&1; fi
      for s in $seeds; do wait_slot
        run_one "sdd-m-syn6-s$s" 600 --config host-trainer/configs/sdd-m-tiny-syn6.toml --pool "$pool" --seed "$s" & done ;;
    eth) for sc in eth hotel univ zara1 zara2; do for s in $seeds; do wait_slot
        run_one "eth-$sc-s$s" 150 --config host-trainer/configs/ethucy-tiny.toml --dataset "eth_ucy:$sc" --seed "$s" & done; done ;;
    levers) for s in $seeds; do wait_slot
        run_one "sdd-m-mirror-s$s" 600 --config host-trainer/configs/sdd-m-tiny.toml --mirror --seed "$s" & done
      for s in $seeds; do wait_slot
        run_one "sdd-m-speed-s$s" 600 --config host-trainer/configs/sdd-m-tiny-speed.toml --seed "$s" & done ;;
    *) echo "unknown group $g"; exit 2 ;;
  esac
done
wait
