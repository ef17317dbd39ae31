#!/usr/bin/env bash
# The learned-latent study of docs/latents.md: every proposal variant, 3 seeds, trained
# post hoc on the frozen metric model weights/sdd-m-tiny.gpec, two runs at a time, one
# thread each. Resumable: a finished run (proposal.json present) is skipped, an
# interrupted one continues from its checkpoint (`gpecnet propose --resume`).
#
#   scripts/latents-runs.sh [OUT]          # OUT defaults to runs/latents
#   scripts/latents-summary.sh [OUT]       # mean ± std of each variant's best validation epoch
#
# About 1 s per epoch and run on a 2020s x86 core (100 epochs: ~2 min); 16 runs, ~25 min on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-runs/latents}
mkdir -p "$out"
cargo build --release -q -p gpecnet-trainer
bin=target/release/gpecnet
variants=(
  "cb --epochs 100 --codebook"
  "h8 --epochs 100 --hidden 8"
  "h10e100 --epochs 100 --hidden 10"
  "h10 --epochs 200 --hidden 10"
  "h12 --epochs 100 --hidden 12"
  "h64 --epochs 150 --hidden 64"
)
jobs=()
for v in "${variants[@]}"; do
  read -r name args <<<"$v"
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
printf '%s\n' "${jobs[@]}" | xargs -P 2 -L 1 bash -c 'run "$@"' _
