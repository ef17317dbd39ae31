#!/usr/bin/env bash
# Neighbours, measured before built (docs/planner-neighbours.md): does PECNet's non-local
# social pooling help the tiny ETH/UCY recipe? Variant (a) raw = no pooling, (b) social =
# pooling on; everything else identical (host-trainer/configs/ethucy-tiny-{raw,social}.toml).
# Judged on each scene's VALIDATION split only (the training's own validation: K = 20,
# sigma = 1.3, best epoch by val minFDE); the test split is never read.
#
# Run from the repository root, after `cargo build --release -p gpecnet-trainer --bin gpecnet`:
#   scripts/neighbours-runs.sh            # trains what is missing, then prints the table
# One training at a time, single thread, niced. Resumable: a finished run (EPOCHS epochs in
# metrics.csv) is skipped, an interrupted one is continued bit-exactly with --resume.
# Environment overrides (defaults in brackets):
#   DATA [../shared/data]  BIN [target/release/gpecnet]  RUNS [runs/neighbours]
#   CONFIGS [host-trainer/configs]  EPOCHS [100]  SCENES ["univ zara1"]  SEEDS ["1 2 3"]
#   VARIANTS ["raw social"]
set -euo pipefail

DATA=${DATA:-../shared/data}
BIN=${BIN:-target/release/gpecnet}
RUNS=${RUNS:-runs/neighbours}
CONFIGS=${CONFIGS:-host-trainer/configs}
EPOCHS=${EPOCHS:-100}
SCENES=${SCENES:-univ zara1}
SEEDS=${SEEDS:-1 2 3}
VARIANTS=${VARIANTS:-raw social}

mkdir -p "$RUNS"
WALL="$RUNS/wall.tsv"   # run, epochs reached, seconds of this invocation (resumes add lines)
[ -f "$WALL" ] || printf 'run\tepochs\tseconds\n' > "$WALL"

epochs_done() {   # last epoch number in metrics.csv, 0 if none
    local f="$1/metrics.csv"
    [ -f "$f" ] && tail -n 1 "$f" | cut -d, -f1 | grep -E '^[0-9]+$' || echo 0
}

# Order: all cheap raw runs first, then the slower social ones (social pooling is ~7-8x
# slower per epoch: groups are never split, so batches and masks are large).
for variant in $VARIANTS; do
  for scene in $SCENES; do
    for seed in $SEEDS; do
      out="$RUNS/$scene-$variant-s$seed"
      done_e=$(epochs_done "$out")
      if [ "$done_e" -ge "$EPOCHS" ]; then
        echo "skip $out (epoch $done_e >= $EPOCHS)"
        continue
      fi
      t0=$(date +%s)
      if [ -f "$out/checkpoint.bin" ]; then
        echo "resume $out (epoch $done_e -> $EPOCHS)"
        nice -n 10 "$BIN" train --resume --out "$out" --data "$DATA" --epochs "$EPOCHS" --quiet
      else
        echo "train $out"
        nice -n 10 "$BIN" train --config "$CONFIGS/ethucy-tiny-$variant.toml" --data "$DATA" \
          --dataset "eth_ucy:$scene" --seed "$seed" --epochs "$EPOCHS" --out "$out" --quiet
      fi
      printf '%s\t%s\t%s\n' "$(basename "$out")" "$(epochs_done "$out")" "$(( $(date +%s) - t0 ))" >> "$WALL"
    done
  done
done

# Table: best epoch by validation minFDE (the trainer's own choice), its val minADE/minFDE.
echo
printf 'scene\tvariant\tseed\tbest_epoch\tval_minADE\tval_minFDE\n'
for scene in $SCENES; do
  for variant in $VARIANTS; do
    for seed in $SEEDS; do
      f="$RUNS/$scene-$variant-s$seed/metrics.csv"
      [ -f "$f" ] || continue
      awk -F, -v s="$scene" -v v="$variant" -v seed="$seed" -v E="$EPOCHS" '
        NR > 1 && $1 <= E && (best == "" || $7 < bf) { best = $1; ba = $6; bf = $7 }
        END { printf "%s\t%s\t%s\t%d\t%.4f\t%.4f\n", s, v, seed, best, ba, bf }' "$f"
    done
  done
done
