#!/usr/bin/env bash
# The widest-decoder study of docs/latents.md: the metric MCU recipe's CVAE with its decoder at
# 48 (sdd-m-tiny.toml, the shipped width, which leaves 18 B of the 64 KiB) and 56
# (sdd-m-tiny-dec56.toml, one more kilobyte) wide, 3 seeds each, then the shipped 8-wide latent proposal for
# each CVAE (the CVAE's seed), compared on validation. Resumable: every stage is skipped when
# its output exists, training and proposals continue from their checkpoints.
#
#   scripts/decoder-width-runs.sh [OUT]      # OUT defaults to runs/gen
#   scripts/latents-summary.py OUT/props     # mean ± std of each width's validation numbers
#
# Per width w in {48: sdd-m-mirror, 56: dec56} and seed s in 1 2 3:
#   gpecnet train --config <config> --mirror --seed s --epochs 600 --out OUT/<run>-s<s>
#   gpecnet export --run OUT/<run>-s<s> --name <run>-s<s> --out OUT/models --sigma 1.3 --tts 0
#   gpecnet propose --blob OUT/models/<run>-s<s>.gpec --hidden 8 --seed s --epochs 100
#       --out OUT/props/h8w<w>-s<s>
# (sdd-m-mirror-s2 is the shipped CVAE, weights/sdd-m-tiny.gpec bit for bit.)
# BIN names another gpecnet binary (default: target/release/gpecnet, built first); JOBS=2.
# About 4 min per CVAE and 2-3 min per proposal on one 2020s x86 core; ~20 min on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-runs/gen}
if [ -z "${BIN:-}" ]; then
  cargo build --release -q -p gpecnet-trainer
fi
bin=${BIN:-target/release/gpecnet}
mkdir -p "$out/models" "$out/props"
run() { # run-name config width seed
  local name=$1-s$4 cfg=$2 w=$3 s=$4
  local dir=$out/$name log=$out/$name.log
  if [ ! -f "$dir/checkpoint.bin" ]; then
    "$bin" train --config "$cfg" --mirror --seed "$s" --epochs 600 --out "$dir" --quiet >"$log" 2>&1 || return 1
  elif [ "$(($(wc -l <"$dir/metrics.jsonl")))" -lt 600 ]; then
    "$bin" train --resume --out "$dir" --epochs 600 --quiet >>"$log" 2>&1 || return 1
  fi
  [ -f "$out/models/$name.gpec" ] ||
    "$bin" export --run "$dir" --name "$name" --out "$out/models" --sigma 1.3 --tts 0 >>"$log" 2>&1 || return 1
  [ -f "$out/props/h8w$w-s$s/proposal.json" ] ||
    "$bin" propose --blob "$out/models/$name.gpec" --dataset sdd-m --hidden 8 --seed "$s" \
      --epochs 100 --out "$out/props/h8w$w-s$s" --resume >>"$log" 2>&1 || return 1
  echo "done $name"
}
export -f run
export out bin
for s in 1 2 3; do
  printf '%s\n' "sdd-m-mirror host-trainer/configs/sdd-m-tiny.toml 48 $s" \
    "dec56 host-trainer/configs/sdd-m-tiny-dec56.toml 56 $s"
done | xargs -P "${JOBS:-2}" -L 1 bash -c 'run "$@"' _
