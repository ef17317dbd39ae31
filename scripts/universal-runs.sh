#!/usr/bin/env bash
# Protocol (a) of docs/generalisation.md ("One model for every scene"): SDD in metres
# + four ETH/UCY scenes -> the fifth, the shipped default's recipe (sdd-m-tiny.toml, --mirror,
# then a learned 8-wide proposal, endpoint scores, endpoint-only fixed point), 3 seeds per
# target scene. Every choice is made on the combined validation split (the five SDD validation
# scenes + the four training scenes' val/); the test sets are read only by export (combined test,
# reported nowhere) and eval (each target separately, the numbers of the doc).
#
# Per run uni-<scene>-s<seed> under $RUNS (default runs/universal), each stage skipped when its
# output exists, training resumed from its checkpoint when interrupted:
#   1. train    --config host-trainer/configs/sdd-m-tiny.toml --mirror
#               --dataset sdd-m+eth_ucy:<scene> --seed <seed> --epochs $EPOCHS (default 150)
#   2. export   the best-validation epoch's CVAE (f32; sigma unused once a proposal is attached)
#   3. propose  --hidden 8 --seed <seed> --epochs $PEPOCHS (default 25) on the combined data
#   4. score    endpoint probabilities and radii (the shipped settings)
#   5. export   with proposal + scores, then quantize --endpoint-only (the MCU form)
#   6. eval     the fixed-point blob on eth_ucy:<scene> and on sdd-m -> <run>-<target>.json
# plus the shipped default weights/sdd-m-lp-qe.gpec on the same targets (baseline/).
#
# Usage: [BIN=path/to/gpecnet] [JOBS=1] [SEEDS="1 2 3"] scripts/universal-runs.sh [SCENE...]
#        (scenes: eth hotel univ zara1 zara2; default: all five, as run for the doc)
# Cost on one 2020s x86 core (the dev-profile binary, measured): eth 2.0 s per training epoch
# (37,457 windows x 4 with time reversal + mirror), ~7 s per proposal epoch; univ about half.
# One eth run ~10-12 min, one univ run ~5.5 min; the 15 runs took 121 min of wall time on 2
# shared cores (one process, a second only while the machine was idle).
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${RUNS:-runs/universal}
jobs=${JOBS:-1}
seeds=${SEEDS:-"1 2 3"}
epochs=${EPOCHS:-150}
pepochs=${PEPOCHS:-25}
if [ -z "${BIN:-}" ]; then
  cargo build --release -q -p gpecnet-trainer
  BIN=target/release/gpecnet
fi
scenes=${*:-"eth hotel univ zara1 zara2"}
models=$runs/models
mkdir -p "$models" "$runs/baseline"

eval_to() { # blob, target, json
  [ -f "$3" ] && return 0
  "$BIN" eval --blob "$1" --dataset "$2" --json --draw "${3%.json}.svg" >"$3.tmp" && mv "$3.tmp" "$3"
}

one() { # scene seed
  local sc=$1 s=$2 name=uni-$1-s$2
  local out=$runs/$name ds=sdd-m+eth_ucy:$1 log=$runs/$name.log
  local done_epochs=0
  [ -f "$out/metrics.jsonl" ] && done_epochs=$(wc -l <"$out/metrics.jsonl")
  if [ -f "$out/checkpoint.bin" ]; then
    [ "$done_epochs" -ge "$epochs" ] || "$BIN" train --resume --out "$out" --quiet --epochs "$epochs" >>"$log" 2>&1 || return 1
  else
    "$BIN" train --config host-trainer/configs/sdd-m-tiny.toml --mirror --dataset "$ds" \
      --seed "$s" --epochs "$epochs" --out "$out" --quiet >"$log" 2>&1 || return 1
  fi
  [ -f "$models/$name.gpec" ] ||
    "$BIN" export --run "$out" --name "$name" --out "$models" --sigma 1.3 --tts 0 >>"$log" 2>&1 || return 1
  [ -f "$out-h8/proposal.json" ] ||
    "$BIN" propose --blob "$models/$name.gpec" --dataset "$ds" --hidden 8 --seed "$s" \
      --epochs "$pepochs" --out "$out-h8" --resume >>"$log" 2>&1 || return 1
  [ -f "$out-score/score.json" ] ||
    "$BIN" score --blob "$models/$name.gpec" --proposal "$out-h8/proposal.json" --dataset "$ds" \
      --l2 0,0.0001,0.001,0.01 --iters 400 --lr 0.05 --out "$out-score" >>"$log" 2>&1 || return 1
  [ -f "$models/$name-lp.gpec" ] ||
    "$BIN" export --run "$out" --name "$name-lp" --out "$models" --sigma 1.3 --tts 0 \
      --proposal "$out-h8/proposal.json" --score "$out-score/score.json" >>"$log" 2>&1 || return 1
  [ -f "$models/$name-lp-qe.gpec" ] ||
    "$BIN" quantize --endpoint-only --blob "$models/$name-lp.gpec" --out "$models/$name-lp-qe.gpec" >>"$log" 2>&1 || return 1
  eval_to "$models/$name-lp-qe.gpec" "eth_ucy:$sc" "$runs/$name-eth_ucy_$sc.json" || return 1
  eval_to "$models/$name-lp-qe.gpec" sdd-m "$runs/$name-sdd-m.json" || return 1
  echo "done $name"
}

eval_to weights/sdd-m-lp-qe.gpec sdd-m "$runs/baseline/sdd-m-lp-qe-sdd-m.json"
for sc in $scenes; do
  eval_to weights/sdd-m-lp-qe.gpec "eth_ucy:$sc" "$runs/baseline/sdd-m-lp-qe-eth_ucy_$sc.json"
done

wait_slot() { while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do sleep 5; done; }
for sc in $scenes; do
  for s in $seeds; do
    wait_slot
    one "$sc" "$s" || echo "FAILED uni-$sc-s$s (see $runs/uni-$sc-s$s.log)" &
  done
done
wait
