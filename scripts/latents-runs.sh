#!/usr/bin/env bash
# The learned-latent study of docs/latents.md: every proposal variant, 3 seeds, trained
# on the metric model weights/sdd-m-tiny.gpec (post hoc, its networks frozen; or jointly
# with its decoder: the `j` variants), two runs at a time, one thread each. Resumable: a
# finished run (proposal.json present) is skipped, an interrupted one continues from its
# checkpoint (`gpecnet propose --resume`).
#
#   scripts/latents-runs.sh [OUT [VARIANT...]]   # OUT defaults to runs/latents; all variants
#   scripts/latents-summary.py [OUT]             # mean ± std of each variant's validation numbers
#
# BIN names another gpecnet binary (default: target/release/gpecnet, built first); JOBS
# the runs at a time (default 2).
# About 1 s per epoch and run on a 2020s x86 core (100 epochs: ~2 min); 16 runs of the
# post-hoc variants, ~25 min on 2 cores; the 21 joint and starter runs, ~40 min.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-runs/latents}
shift || true
mkdir -p "$out"
if [ -z "${BIN:-}" ]; then
  cargo build --release -q -p gpecnet-trainer
fi
bin=${BIN:-target/release/gpecnet}
variants=(
  "cb --epochs 100 --codebook"
  "h8 --epochs 100 --hidden 8"
  "h10e100 --epochs 100 --hidden 10"
  "h10 --epochs 200 --hidden 10"
  "h12 --epochs 100 --hidden 12"
  "h64 --epochs 150 --hidden 64"
  # joint training: the decoder trained with the proposal (its own learning rate)
  "j8 --epochs 100 --hidden 8 --tune-decoder --decoder-lr 1e-4"
  "j8lr3 --epochs 100 --hidden 8 --tune-decoder --decoder-lr 3e-4"
  "j64 --epochs 150 --hidden 64 --tune-decoder --decoder-lr 1e-4"
  # starters (standing when forecast, > 1 m away at the horizon) weigh 3 windows each
  "h8st3 --epochs 100 --hidden 8 --starter-weight 3"
  "j8st3 --epochs 100 --hidden 8 --tune-decoder --decoder-lr 1e-4 --starter-weight 3"
  "h8st10 --epochs 100 --hidden 8 --starter-weight 10"
  "h8st30 --epochs 100 --hidden 8 --starter-weight 30"
  # distilled from the 64-wide host proposal on the same CVAE (weights/sdd-m-lp-host.gpec)
  "h8d03 --epochs 100 --hidden 8 --teacher weights/sdd-m-lp-host.gpec --distill-weight 0.3"
  "h8d1 --epochs 100 --hidden 8 --teacher weights/sdd-m-lp-host.gpec --distill-weight 1"
  "h8d3 --epochs 100 --hidden 8 --teacher weights/sdd-m-lp-host.gpec --distill-weight 3"
  # synthetic starters (and stoppers) on real observed pasts, 5 % of the training windows each
  "h8ss5 --epochs 100 --hidden 8 --synthetic-starters 0.05"
  "h8sss5 --epochs 100 --hidden 8 --synthetic-starters 0.05 --synthetic-stoppers 0.05"
)
jobs=()
for v in "${variants[@]}"; do
  read -r name args <<<"$v"
  if [ $# -gt 0 ] && ! printf '%s\n' "$@" | grep -qx "$name"; then
    continue
  fi
  for seed in 0 1 2; do
    jobs+=("$name-s$seed --seed $seed $args")
  done
done
run() {
  local name=$1
  shift
  [ -f "$out/$name/proposal.json" ] && return 0
  "$bin" propose --blob weights/sdd-m-tiny.gpec --dataset sdd-m --out "$out/$name" --resume "$@" \
    >"$out/$name.log" 2>&1
}
export -f run
export out bin
printf '%s\n' "${jobs[@]}" | xargs -P "${JOBS:-2}" -L 1 bash -c 'run "$@"' _
