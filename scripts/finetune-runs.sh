#!/usr/bin/env bash
# Fine-tuning study (docs/own-data.md, "Fine-tuning"): on each ETH/UCY scene's leave-one-out
# training split, with a fixed 10 % of its tracks and with all of them, the shipped f32 model
# fine-tuned (`gpecnet train --init weights/sdd-m-lp.gpec`) against the same recipe trained
# from scratch (host-trainer/configs/sdd-m-tiny.toml, data_scale computed from the data), each
# then given a learned proposal and endpoint scores refitted on the same training tracks, and
# both against the shipped model zero-shot. 3 seeds each; the best epoch is chosen on the
# scene's validation split, the test split is evaluated once per model.
#
# Per run <scene>-<ft|scratch>-f<10|100>-s<seed> under $RUNS (default target/finetune/runs),
# each stage skipped when its output exists, training and the proposal resumed when
# interrupted:
#   1. train    ft:      --init weights/sdd-m-lp.gpec --epochs $FT_EPOCHS (default 100 at
#                        10 %, $FT_EPOCHS_FULL = 30 at 100 %)
#               scratch: --config host-trainer/configs/sdd-m-tiny.toml --mirror
#                        --data-scale auto --epochs $SCRATCH_EPOCHS (default 300 at 10 %,
#                        $SCRATCH_EPOCHS_FULL = 150 at 100 %, as docs/ethucy.md's runs)
#               both:    --dataset eth_ucy:<scene> --train-fraction <0.1|1> --seed <seed>
#   2. export   the best-validation epoch (f32, --sigma 1.3 --tts 0)
#   3. propose  the shipped settings (--seed 1 --k 20 --hidden 8 --act relu --batch 256
#               --lr 0.001 --prior-weight 0.02 --temperature 0.05 --bound 8), --epochs $PEPOCHS
#               (default 100 at 10 %, $PEPOCHS_FULL = 30 at 100 %), the same --train-fraction
#   4. score    --l2 0,0.0001,0.001,0.01 --iters 400 --lr 0.05, the same --train-fraction
#   5. export   with proposal and scores (f32: the comparison is about the weights, so no
#               fixed-point step, whose calibration would read the whole training split)
#   6. eval     eth_ucy:<scene> test (--json)
# The zero-shot rows are `gpecnet eval --blob weights/sdd-m-lp.gpec --dataset eth_ucy:<scene>`.
# scripts/finetune-summary.py tabulates $RUNS/json/.
#
# Usage: [BIN=path/to/gpecnet] [JOBS=1] [SEEDS="1 2 3"] [SCENES="eth hotel univ zara1 zara2"]
#        scripts/finetune-runs.sh [FRACTION...]   (default: 10 100)
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${RUNS:-target/finetune/runs}
jobs=${JOBS:-1}
seeds=${SEEDS:-"1 2 3"}
scenes=${SCENES:-"eth hotel univ zara1 zara2"}
ft_epochs=${FT_EPOCHS:-100}
scratch_epochs=${SCRATCH_EPOCHS:-300}
ft_epochs_full=${FT_EPOCHS_FULL:-30}
scratch_epochs_full=${SCRATCH_EPOCHS_FULL:-150}
pepochs=${PEPOCHS:-100}
pepochs_full=${PEPOCHS_FULL:-30}
init=${INIT:-weights/sdd-m-lp.gpec}
if [ -z "${BIN:-}" ]; then
  cargo build --release -q -p gpecnet-trainer --bin gpecnet
  BIN=target/release/gpecnet
fi
fractions=${*:-"10 100"}
models=$runs/models
json=$runs/json
mkdir -p "$models" "$json"

to_json() { # out.json, command...
  local out=$1
  shift
  [ -f "$out" ] && return 0
  "$@" --json >"$out.tmp" && mv "$out.tmp" "$out"
}

one() { # scene method fraction(10|100) seed
  local sc=$1 method=$2 pct=$3 seed=$4
  local name=$sc-$method-f$pct-s$seed frac pe
  local out=$runs/$name log=$runs/$name.log
  local epochs
  if [ "$pct" = 100 ]; then
    frac=1
    pe=$pepochs_full
    epochs=$ft_epochs_full
    [ "$method" = scratch ] && epochs=$scratch_epochs_full
  else
    frac=0.$pct
    pe=$pepochs
    epochs=$ft_epochs
    [ "$method" = scratch ] && epochs=$scratch_epochs
  fi
  if [ -f "$out/checkpoint.bin" ]; then
    [ "$(wc -l <"$out/metrics.jsonl")" -ge "$epochs" ] ||
      "$BIN" train --resume --out "$out" --quiet --epochs "$epochs" >>"$log" 2>&1 || return 1
  elif [ "$method" = ft ]; then
    "$BIN" train --init "$init" --dataset "eth_ucy:$sc" --train-fraction "$frac" --seed "$seed" \
      --epochs "$epochs" --out "$out" --quiet --force >"$log" 2>&1 || return 1
  else
    "$BIN" train --config host-trainer/configs/sdd-m-tiny.toml --mirror --data-scale auto \
      --dataset "eth_ucy:$sc" --train-fraction "$frac" --seed "$seed" \
      --epochs "$epochs" --out "$out" --quiet --force >"$log" 2>&1 || return 1
  fi
  [ -f "$models/$name.gpec" ] ||
    "$BIN" export --run "$out" --name "$name" --out "$models" --sigma 1.3 --tts 0 >>"$log" 2>&1 || return 1
  [ -f "$out-h8/proposal.json" ] ||
    "$BIN" propose --blob "$models/$name.gpec" --dataset "eth_ucy:$sc" --seed 1 --k 20 --hidden 8 \
      --act relu --epochs "$pe" --batch 256 --lr 0.001 --prior-weight 0.02 \
      --temperature 0.05 --bound 8 --train-fraction "$frac" --out "$out-h8" --resume >>"$log" 2>&1 || return 1
  [ -f "$out-score/score.json" ] ||
    "$BIN" score --blob "$models/$name.gpec" --proposal "$out-h8/proposal.json" \
      --dataset "eth_ucy:$sc" --train-fraction "$frac" \
      --l2 0,0.0001,0.001,0.01 --iters 400 --lr 0.05 --out "$out-score" >>"$log" 2>&1 || return 1
  [ -f "$models/$name-lp.gpec" ] ||
    "$BIN" export --run "$out" --name "$name-lp" --out "$models" --sigma 1.3 --tts 0 \
      --proposal "$out-h8/proposal.json" --score "$out-score/score.json" >>"$log" 2>&1 || return 1
  to_json "$json/$name.json" "$BIN" eval --blob "$models/$name-lp.gpec" --dataset "eth_ucy:$sc" \
    >>"$log" 2>&1 || return 1
  echo "done $name"
}

for sc in $scenes; do
  to_json "$json/$sc-zeroshot.json" "$BIN" eval --blob "$init" --dataset "eth_ucy:$sc"
done
wait_slot() { while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do sleep 5; done; }
for pct in $fractions; do
  for s in $seeds; do
    for sc in $scenes; do
      for method in ft scratch; do
        wait_slot
        { one "$sc" "$method" "$pct" "$s" || echo "FAILED $sc-$method-f$pct-s$s (see $runs/$sc-$method-f$pct-s$s.log)"; } &
      done
    done
  done
done
wait
