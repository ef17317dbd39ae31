#!/usr/bin/env bash
# Protocol (a) of docs/generalisation.md ("One model for every scene"): SDD in metres
# + four ETH/UCY scenes -> the fifth, 3 seeds per target scene, in one of two modes. Every
# choice is made on the combined validation split (the five SDD validation scenes + the four
# training scenes' val/); the test sets are read only by export (the CVAE's own test set,
# reported nowhere) and eval (each target separately, the numbers of the doc).
#
# MODE=cvae (default): the shipped default's recipe trained on the combined data: per run
# uni-<scene>-s<seed> under $RUNS (default runs/universal)
#   1. train    --config host-trainer/configs/sdd-m-tiny.toml --mirror
#               --dataset sdd-m+eth_ucy:<scene> --seed <seed> --epochs $EPOCHS (default 150)
#   2. export   the best-validation epoch's CVAE (f32; sigma unused once a proposal is attached)
#   3. propose  --hidden 8 --seed <seed> --epochs $PEPOCHS (default 25) on the combined data
#   With TAG=<tag> CONFIG=<toml> [POOL=<synthetic pool>]: that config (and pool) in step 1
#   (say TAG=syn6 CONFIG=host-trainer/configs/sdd-m-tiny-syn6.toml POOL=runs/gen/pool6k.csv:
#   6 % synthetic trajectories): per run uni<tag>-<scene>-s<seed> under runs/universal-<tag>.
# MODE=joint: the shipped default's CVAE kept (encoder and point head trained on SDD alone),
# its decoder and the 8-wide proposal trained jointly on the combined data, each data set
# weighing half of the loss and of the validation score: per run jb-<scene>-s<seed> under
# $RUNS (default runs/universal-joint)
#   3. propose  --blob weights/sdd-m-tiny.gpec --hidden 8 --tune-decoder --decoder-lr
#               $DECODER_LR (default 1e-4) --balance --seed <seed> --epochs $PEPOCHS (default 30)
#      with the CVAE's run $CVAE (default runs/gen/sdd-m-mirror-s2: weights/sdd-m-tiny.gpec,
#      bit for bit, from `gpecnet train --config host-trainer/configs/sdd-m-tiny.toml --mirror
#      --seed 2 --epochs 600 --out runs/gen/sdd-m-mirror-s2`)
# MODE=jointpoint: MODE=joint with the CVAE's point head trained beside the proposal on the
# same balanced batches (`--tune-point-head --point-lr $POINT_LR`, default 1e-4, selected on
# its own balanced validation FDE): per run jbp-<scene>-s<seed> under $RUNS (default
# runs/universal-joint-point). The proposal and decoder train exactly as in MODE=joint.
# With SPEED=0.8,1.25 (say), every training window also walked at those speeds
# (`--speed-scales`): per run jbps-<scene>-s<seed> under runs/universal-joint-point-speed.
# MODE=joint with TAG=<tag> EXTRA="<propose options>": the joint recipe with more options
# (say TAG=st10 EXTRA="--starter-weight 10"): per run jb<tag>-<scene>-s<seed> under
# runs/universal-joint-<tag>.
# then, in every mode:
#   4. score    endpoint probabilities and radii (the shipped settings)
#   5. export   with proposal + scores, then quantize --endpoint-only (the MCU form)
#   6. eval     the fixed-point blob on eth_ucy:<scene> and on sdd-m -> <run>-<target>.json
#   7. stream   the held-out scene's test recordings through the track table and the online
#               loop (`gpecnet stream`: r50 / r90 coverage as deployed) -> <run>-stream-<scene>.json
# plus the shipped default weights/sdd-m-lp-qe.gpec on the same targets (baseline/).
# Each stage is skipped when its output exists; training and proposals resume from their
# checkpoints when interrupted.
#
# Usage: [MODE=cvae|joint|jointpoint] [BIN=path/to/gpecnet] [JOBS=1] [SEEDS="1 2 3"] scripts/universal-runs.sh [SCENE...]
#        (scenes: eth hotel univ zara1 zara2; default: all five, as run for the doc)
# Cost on one 2020s x86 core (the dev-profile binary, measured): MODE=cvae: eth 2.0 s per
# training epoch (37,457 windows x 4 with time reversal + mirror), ~7 s per proposal epoch;
# univ about half. One eth run ~10-12 min, one univ run ~5.5 min; the 15 runs took 121 min of
# wall time on 2 shared cores (one process, a second only while the machine was idle).
# MODE=joint (release binary): ~5 s per proposal epoch on the eth split, one run ~5 min.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${MODE:-cvae}
case $mode in
  cvae) runs=${RUNS:-runs/universal${TAG:+-$TAG}} pepochs=${PEPOCHS:-25} prefix=uni${TAG:-} ;;
  joint) runs=${RUNS:-runs/universal-joint${TAG:+-$TAG}} pepochs=${PEPOCHS:-30} prefix=jb${TAG:-} ;;
  jointpoint)
    if [ -n "${SPEED:-}" ]; then
      runs=${RUNS:-runs/universal-joint-point-speed} prefix=jbps
    else
      runs=${RUNS:-runs/universal-joint-point} prefix=jbp
    fi
    pepochs=${PEPOCHS:-30} ;;
  *) echo "MODE is cvae, joint or jointpoint, not $mode" >&2; exit 2 ;;
esac
jobs=${JOBS:-1}
seeds=${SEEDS:-"1 2 3"}
epochs=${EPOCHS:-150}
dlr=${DECODER_LR:-1e-4}
plr=${POINT_LR:-1e-4}
cvae=${CVAE:-runs/gen/sdd-m-mirror-s2}
if [ -z "${BIN:-}" ]; then
  cargo build --release -q -p gpecnet-trainer
  BIN=target/release/gpecnet
fi
if [ "$mode" != cvae ] && [ ! -f "$cvae/checkpoint.bin" ]; then
  echo "no CVAE run at $cvae (see the header)" >&2
  exit 1
fi
scenes=${*:-"eth hotel univ zara1 zara2"}
models=$runs/models
mkdir -p "$models" "$runs/baseline"

eval_to() { # blob, target, json
  [ -f "$3" ] && return 0
  "$BIN" eval --blob "$1" --dataset "$2" --json --draw "${3%.json}.svg" >"$3.tmp" && mv "$3.tmp" "$3"
}

stream_to() { # blob, target, json: the target's test recordings streamed (loop off and on)
  [ -f "$3" ] && return 0
  "$BIN" stream --blob "$1" --dataset "$2" --json >"$3.tmp" 2>/dev/null && mv "$3.tmp" "$3"
}

# Stages 1-3 of MODE=cvae: the CVAE trained on the combined data, its proposal; sets
# `src` (the run export reads) and `blob` (the f32 blob the proposal was trained for).
cvae_stages() { # scene seed name out ds log
  local sc=$1 s=$2 name=$3 out=$4 ds=$5 log=$6
  local done_epochs=0
  [ -f "$out/metrics.jsonl" ] && done_epochs=$(wc -l <"$out/metrics.jsonl")
  if [ -f "$out/checkpoint.bin" ]; then
    [ "$done_epochs" -ge "$epochs" ] || "$BIN" train --resume --out "$out" --quiet --epochs "$epochs" >>"$log" 2>&1 || return 1
  else
    "$BIN" train --config "${CONFIG:-host-trainer/configs/sdd-m-tiny.toml}" ${POOL:+--pool "$POOL"} --mirror \
      --dataset "$ds" --seed "$s" --epochs "$epochs" --out "$out" --quiet >"$log" 2>&1 || return 1
  fi
  [ -f "$models/$name.gpec" ] ||
    "$BIN" export --run "$out" --name "$name" --out "$models" --sigma 1.3 --tts 0 >>"$log" 2>&1 || return 1
  [ -f "$out-h8/proposal.json" ] ||
    "$BIN" propose --blob "$models/$name.gpec" --dataset "$ds" --hidden 8 --seed "$s" \
      --epochs "$pepochs" --out "$out-h8" --resume >>"$log" 2>&1 || return 1
  src=$out blob=$models/$name.gpec prop=$out-h8
}

# Stage 3 of MODE=joint: the shipped CVAE's decoder and a proposal, trained jointly, balanced.
joint_stages() { # scene seed name out ds log
  local s=$2 out=$4 ds=$5 log=$6
  [ -f "$out/proposal.json" ] ||
    "$BIN" propose --blob weights/sdd-m-tiny.gpec --dataset "$ds" --hidden 8 --tune-decoder \
      --decoder-lr "$dlr" --balance ${EXTRA:-} --seed "$s" --epochs "$pepochs" --out "$out" --resume >"$log" 2>&1 || return 1
  src=$cvae blob=weights/sdd-m-tiny.gpec prop=$out
}

# Stage 3 of MODE=jointpoint: MODE=joint's, with the point head trained beside it.
jointpoint_stages() { # scene seed name out ds log
  local s=$2 out=$4 ds=$5 log=$6
  [ -f "$out/proposal.json" ] ||
    "$BIN" propose --blob weights/sdd-m-tiny.gpec --dataset "$ds" --hidden 8 --tune-decoder \
      --decoder-lr "$dlr" --balance --tune-point-head --point-lr "$plr" ${SPEED:+--speed-scales "$SPEED"} --seed "$s" \
      --epochs "$pepochs" --out "$out" --resume >"$log" 2>&1 || return 1
  src=$cvae blob=weights/sdd-m-tiny.gpec prop=$out
}

one() { # scene seed
  local sc=$1 s=$2 name=$prefix-$1-s$2
  local out=$runs/$name ds=sdd-m+eth_ucy:$1 log=$runs/$name.log
  local src blob prop
  "${mode}_stages" "$sc" "$s" "$name" "$out" "$ds" "$log" || return 1
  [ -f "$out-score/score.json" ] ||
    "$BIN" score --blob "$blob" --proposal "$prop/proposal.json" --dataset "$ds" \
      --l2 0,0.0001,0.001,0.01 --iters 400 --lr 0.05 --out "$out-score" >>"$log" 2>&1 || return 1
  [ -f "$models/$name-lp.gpec" ] ||
    "$BIN" export --run "$src" --name "$name-lp" --out "$models" --sigma 1.3 --tts 0 \
      --proposal "$prop/proposal.json" --score "$out-score/score.json" >>"$log" 2>&1 || return 1
  [ -f "$models/$name-lp-qe.gpec" ] ||
    "$BIN" quantize --endpoint-only --blob "$models/$name-lp.gpec" --out "$models/$name-lp-qe.gpec" >>"$log" 2>&1 || return 1
  eval_to "$models/$name-lp-qe.gpec" "eth_ucy:$sc" "$runs/$name-eth_ucy_$sc.json" || return 1
  eval_to "$models/$name-lp-qe.gpec" sdd-m "$runs/$name-sdd-m.json" || return 1
  stream_to "$models/$name-lp-qe.gpec" "eth_ucy:$sc" "$runs/$name-stream-$sc.json" || return 1
  echo "done $name"
}

eval_to weights/sdd-m-lp-qe.gpec sdd-m "$runs/baseline/sdd-m-lp-qe-sdd-m.json"
for sc in $scenes; do
  eval_to weights/sdd-m-lp-qe.gpec "eth_ucy:$sc" "$runs/baseline/sdd-m-lp-qe-eth_ucy_$sc.json"
  stream_to weights/sdd-m-lp-qe.gpec "eth_ucy:$sc" "$runs/baseline/sdd-m-lp-qe-stream-$sc.json"
done

wait_slot() { while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do sleep 5; done; }
for sc in $scenes; do
  for s in $seeds; do
    wait_slot
    one "$sc" "$s" || echo "FAILED $prefix-$sc-s$s (see $runs/$prefix-$sc-s$s.log)" &
  done
done
wait
