#!/usr/bin/env bash
# Noise-aware training (docs/camera.md, "Noise-aware training"): the shipped default's recipe
# (sdd-m-tiny.toml --mirror, then the 8-wide learned proposal, endpoint scores and the
# endpoint-only fixed point, as weights/sdd-m-lp.md and weights/sdd-m-lp-qe.md were produced)
# with i.i.d. Gaussian noise of sigma metres on the 8 observed positions of every training window,
# fresh every epoch (`gpecnet train --obs-noise`, `gpecnet propose --obs-noise`), against the
# same recipe without noise, 3 seeds each. Every run is then streamed like docs/camera.md's
# noise study: the five ETH/UCY scenes zero-shot, clean, with 0.1 m detection noise (filter off)
# and with the filter (--filter --filter-sigma 0.1), on the validation split (where sigma_train is
# chosen) and on the test split (touched once per candidate), plus `gpecnet eval` on sdd-m.
#
# Groups, each one run per seed under $RUNS (default target/noise/runs):
#   clean  no noise (sigma 0: today's training, bit for bit)
#   n010   sigma_train = 0.1 m
#   n005   sigma_train = 0.05 m
#   base   only the streams and the sdd-m eval of the shipped weights/sdd-m-lp-qe.gpec
# Per run <group>-s<seed>, each stage skipped when its output exists, training and the proposal
# resumed from their checkpoints when interrupted:
#   1. train    --config host-trainer/configs/sdd-m-tiny.toml --mirror --seed <seed>
#               [--obs-noise sigma] --epochs $EPOCHS (default 600, as the shipped run)
#   2. export   the best-validation epoch's CVAE (f32)
#   3. propose  the shipped settings (--seed 1 --k 20 --hidden 8 --act relu --epochs $PEPOCHS
#               (default 100) --batch 256 --lr 0.001 --prior-weight 0.02 --temperature 0.05
#               --bound 8) [--obs-noise sigma]
#   4. score    --l2 0,0.0001,0.001,0.01 --iters 400 --lr 0.05
#   5. export   with proposal and scores (--sigma 1.3 --tts 0), then quantize --endpoint-only
#   6. stream   eth_ucy:<scene> x {val, test} x {clean, noise 0.1, noise 0.1 + filter} (--json)
#      eval     the windows of eth_ucy:<scene> test and of sdd-m test (--json)
# Outputs: $RUNS/<run>/ (training), $RUNS/<run>-h8/ (proposal), $RUNS/<run>-score/,
# $RUNS/models/<run>{,-lp,-lp-qe}.gpec, $RUNS/json/<run>-<scene>-<split>-<condition>.json and
# $RUNS/json/<run>-<scene>-eval.json, $RUNS/json/<run>-sdd-m.json; scripts/noise-summary.py
# tabulates them.
#
# Usage: [BIN=path/to/gpecnet] [JOBS=1] [SEEDS="1 2 3"] [EPOCHS=600] [PEPOCHS=100]
#        scripts/noise-runs.sh [GROUP...]   (default: base clean n010)
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${RUNS:-target/noise/runs}
jobs=${JOBS:-1}
seeds=${SEEDS:-"1 2 3"}
epochs=${EPOCHS:-600}
pepochs=${PEPOCHS:-100}
if [ -z "${BIN:-}" ]; then
  cargo build --release -q -p gpecnet-trainer --bin gpecnet
  BIN=target/release/gpecnet
fi
groups=${*:-"base clean n010"}
models=$runs/models
json=$runs/json
mkdir -p "$models" "$json"

sigma_of() { # group -> sigma_train
  case $1 in
    clean) echo 0 ;;
    n010) echo 0.1 ;;
    n005) echo 0.05 ;;
    *) echo "unknown group $1" >&2; return 2 ;;
  esac
}

to_json() { # out.json, command...
  local out=$1
  shift
  [ -f "$out" ] && return 0
  "$@" --json >"$out.tmp" && mv "$out.tmp" "$out"
}

streams() { # name, blob
  local name=$1 blob=$2 sc split
  for sc in hotel zara1 zara2 eth univ; do
    for split in val test; do
      to_json "$json/$name-$sc-$split-clean.json" \
        "$BIN" stream --blob "$blob" --dataset "eth_ucy:$sc" --split "$split" || return 1
      to_json "$json/$name-$sc-$split-noise.json" \
        "$BIN" stream --blob "$blob" --dataset "eth_ucy:$sc" --split "$split" --noise-m 0.1 || return 1
      to_json "$json/$name-$sc-$split-filter.json" \
        "$BIN" stream --blob "$blob" --dataset "eth_ucy:$sc" --split "$split" --noise-m 0.1 \
        --filter --filter-sigma 0.1 || return 1
    done
  done
  for sc in hotel zara1 zara2 eth univ; do
    to_json "$json/$name-$sc-eval.json" "$BIN" eval --blob "$blob" --dataset "eth_ucy:$sc" || return 1
  done
  to_json "$json/$name-sdd-m.json" "$BIN" eval --blob "$blob" --dataset sdd-m || return 1
}

one() { # group seed
  local name=$1-s$2 sigma
  sigma=$(sigma_of "$1")
  local out=$runs/$name log=$runs/$name.log noise=()
  [ "$sigma" = 0 ] || noise=(--obs-noise "$sigma")
  if [ -f "$out/checkpoint.bin" ]; then
    local done_epochs
    done_epochs=$(wc -l <"$out/metrics.jsonl")
    [ "$done_epochs" -ge "$epochs" ] ||
      "$BIN" train --resume --out "$out" --quiet --epochs "$epochs" >>"$log" 2>&1 || return 1
  else
    "$BIN" train --config host-trainer/configs/sdd-m-tiny.toml --mirror --seed "$2" "${noise[@]}" \
      --epochs "$epochs" --out "$out" --quiet --force >"$log" 2>&1 || return 1
  fi
  [ -f "$models/$name.gpec" ] ||
    "$BIN" export --run "$out" --name "$name" --out "$models" --sigma 1.3 --tts 0 >>"$log" 2>&1 || return 1
  [ -f "$out-h8/proposal.json" ] ||
    "$BIN" propose --blob "$models/$name.gpec" --dataset sdd-m --seed 1 --k 20 --hidden 8 \
      --act relu --epochs "$pepochs" --batch 256 --lr 0.001 --prior-weight 0.02 \
      --temperature 0.05 --bound 8 "${noise[@]}" --out "$out-h8" --resume >>"$log" 2>&1 || return 1
  [ -f "$out-score/score.json" ] ||
    "$BIN" score --blob "$models/$name.gpec" --proposal "$out-h8/proposal.json" --dataset sdd-m \
      --l2 0,0.0001,0.001,0.01 --iters 400 --lr 0.05 --out "$out-score" >>"$log" 2>&1 || return 1
  [ -f "$models/$name-lp.gpec" ] ||
    "$BIN" export --run "$out" --name "$name-lp" --out "$models" --sigma 1.3 --tts 0 \
      --proposal "$out-h8/proposal.json" --score "$out-score/score.json" >>"$log" 2>&1 || return 1
  [ -f "$models/$name-lp-qe.gpec" ] ||
    "$BIN" quantize --endpoint-only --blob "$models/$name-lp.gpec" \
      --out "$models/$name-lp-qe.gpec" >>"$log" 2>&1 || return 1
  streams "$name" "$models/$name-lp-qe.gpec" >>"$log" 2>&1 || return 1
  echo "done $name"
}

wait_slot() { while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do sleep 5; done; }
for g in $groups; do
  if [ "$g" = base ]; then
    streams base weights/sdd-m-lp-qe.gpec || echo "FAILED base"
    continue
  fi
  sigma_of "$g" >/dev/null || exit 2
  for s in $seeds; do
    wait_slot
    { one "$g" "$s" || echo "FAILED $g-s$s (see $runs/$g-s$s.log)"; } &
  done
done
wait
