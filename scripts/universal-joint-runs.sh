#!/usr/bin/env bash
# Protocol (a) of docs/generalisation.md with the shipped default's CVAE kept: SDD in metres +
# four ETH/UCY scenes -> the fifth, where only the decoder and the 8-wide latent proposal learn
# from the combined data (`gpecnet propose --tune-decoder --balance`: joint training, each data
# set weighing half of the loss and half of the validation score), while the encoder and the
# point head stay the SDD-trained ones of weights/sdd-m-tiny.gpec. 3 seeds per target scene.
# Every choice is made on the combined validation split; the test sets are read only by export
# (SDD test, the card's numbers, reported nowhere) and eval (each target separately).
#
# Per run jb-<scene>-s<seed> under $RUNS (default runs/universal-joint), each stage skipped when
# its output exists, the proposal resumed from its checkpoint when interrupted:
#   1. propose  --blob weights/sdd-m-tiny.gpec --dataset sdd-m+eth_ucy:<scene> --hidden 8
#               --tune-decoder --decoder-lr $DECODER_LR (default 1e-4) --balance
#               --seed <seed> --epochs $PEPOCHS (default 30)
#   2. score    endpoint probabilities and radii for it (the shipped settings)
#   3. export   the CVAE's run ($CVAE, default runs/gen/sdd-m-mirror-s2: the shipped
#               sdd-m-tiny, retrained by `gpecnet train --config host-trainer/configs/sdd-m-tiny.toml
#               --mirror --seed 2 --epochs 600`) with the proposal (and its decoder) and
#               scores, then quantize --endpoint-only (the MCU form)
#   4. eval     the fixed-point blob on eth_ucy:<scene> and on sdd-m -> <run>-<target>.json
#
# Usage: [BIN=path/to/gpecnet] [JOBS=2] [SEEDS="1 2 3"] scripts/universal-joint-runs.sh [SCENE...]
#        (scenes: eth hotel univ zara1 zara2; default: all five)
# Cost on one 2020s x86 core: ~5 s per proposal epoch on the eth split (37,457 windows x 4 with
# time reversal and mirror), half on univ; one run ~5 min end to end.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${RUNS:-runs/universal-joint}
jobs=${JOBS:-2}
seeds=${SEEDS:-"1 2 3"}
pepochs=${PEPOCHS:-30}
dlr=${DECODER_LR:-1e-4}
cvae=${CVAE:-runs/gen/sdd-m-mirror-s2}
if [ -z "${BIN:-}" ]; then
  cargo build --release -q -p gpecnet-trainer
  BIN=target/release/gpecnet
fi
[ -f "$cvae/checkpoint.bin" ] || { echo "no CVAE run at $cvae (see the header)" >&2; exit 1; }
scenes=${*:-"eth hotel univ zara1 zara2"}
models=$runs/models
mkdir -p "$models"

eval_to() { # blob, target, json
  [ -f "$3" ] && return 0
  "$BIN" eval --blob "$1" --dataset "$2" --json >"$3.tmp" && mv "$3.tmp" "$3"
}

one() { # scene seed
  local sc=$1 s=$2 name=jb-$1-s$2
  local out=$runs/$name ds=sdd-m+eth_ucy:$1 log=$runs/$name.log
  [ -f "$out/proposal.json" ] ||
    "$BIN" propose --blob weights/sdd-m-tiny.gpec --dataset "$ds" --hidden 8 --tune-decoder \
      --decoder-lr "$dlr" --balance --seed "$s" --epochs "$pepochs" --out "$out" --resume >"$log" 2>&1 || return 1
  [ -f "$out-score/score.json" ] ||
    "$BIN" score --blob weights/sdd-m-tiny.gpec --proposal "$out/proposal.json" --dataset "$ds" \
      --l2 0,0.0001,0.001,0.01 --iters 400 --lr 0.05 --out "$out-score" >>"$log" 2>&1 || return 1
  [ -f "$models/$name-lp.gpec" ] ||
    "$BIN" export --run "$cvae" --name "$name-lp" --out "$models" --sigma 1.3 --tts 0 \
      --proposal "$out/proposal.json" --score "$out-score/score.json" >>"$log" 2>&1 || return 1
  [ -f "$models/$name-lp-qe.gpec" ] ||
    "$BIN" quantize --endpoint-only --blob "$models/$name-lp.gpec" --out "$models/$name-lp-qe.gpec" >>"$log" 2>&1 || return 1
  eval_to "$models/$name-lp-qe.gpec" "eth_ucy:$sc" "$runs/$name-eth_ucy_$sc.json" || return 1
  eval_to "$models/$name-lp-qe.gpec" sdd-m "$runs/$name-sdd-m.json" || return 1
  echo "done $name"
}

wait_slot() { while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do sleep 5; done; }
for sc in $scenes; do
  for s in $seeds; do
    wait_slot
    one "$sc" "$s" || echo "FAILED jb-$sc-s$s (see $runs/jb-$sc-s$s.log)" &
  done
done
wait
