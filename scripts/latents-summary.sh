#!/usr/bin/env bash
# Each variant of scripts/latents-runs.sh: its seeds' best validation minFDE (metres, K = 20)
# and clamped share, then mean ± std (sample std, n − 1) over the seeds.
#
#   scripts/latents-summary.sh [OUT]       # OUT defaults to runs/latents
set -euo pipefail
out=${1:-runs/latents}
for dir in "$out"/*-s0; do
  name=$(basename "$dir" -s0)
  best=()
  for s in 0 1 2; do
    f="$out/$name-s$s/metrics.csv"
    [ -f "$f" ] || continue
    # The lowest val_min_fde (column 3) of the run: its selected epoch.
    best+=("$(awk -F, 'NR > 1 && (min == "" || $3 < min) { min = $3; row = $0 } END { print row }' "$f")")
  done
  printf '%s\n' "${best[@]}" | awk -F, -v name="$name" '
    { v[NR] = $3; s += $3; e = e (NR > 1 ? " " : "") $1 }
    END {
      m = s / NR; d = 0
      for (i = 1; i <= NR; i++) d += (v[i] - m) ^ 2
      sd = NR > 1 ? sqrt(d / (NR - 1)) : 0
      printf "%-6s seeds %d  val minFDE %.4f ± %.4f m  (best epochs %s)\n", name, NR, m, sd, e
    }'
done
