#!/usr/bin/env bash
# The side-by-side peer benchmark (not run in CI): gpecnet-core (scalar and
# batched) vs onnxruntime and PyTorch eager on the same weights and latents, one thread each,
# interleaved rounds, medians, ratios; and a training epoch vs PyTorch eager at 1 and 2
# threads. Writes docs/peers.md and prints the short table for the README.
#
#   scripts/peers/bench.sh                 # full run (about 20-30 min on a 2-core box)
#   ROUNDS=1 MODELS=sdd-small TRAIN_CONFIGS=sdd-tiny scripts/peers/bench.sh   # a quick look
#
# Environment (all optional):
#   PEERS_VENV     virtual environment (default target/peers-venv; created if missing)
#   ROUNDS         interleaved inference rounds (default 3)
#   TRAIN_ROUNDS   interleaved training rounds (default 1; each times TRAIN_EPOCHS epochs)
#   TRAIN_EPOCHS   timed epochs per training process, after one warm-up (default 2)
#   MIN_MS         minimum milliseconds of one timing repetition (default 300)
#   REPS           repetitions per case within a process (default 5; median)
#   MODELS         blobs under weights/ (default "sdd-small sdd-paper")
#   TRAIN_CONFIGS  configs under host-trainer/configs (default "sdd-tiny sdd-small sdd-paper")
#   TRAIN_THREADS  thread counts for training (default "1 2")
#   OUT_MD         report path (default docs/peers.md; then README.md's peers table too)
#   SKIP_PREP=1    reuse target/peers (ONNX files, dumps, check results) from an earlier run
#
# Python packages: torch from the PyTorch CPU wheel index when reachable, else from PyPI
# (there it pulls the CUDA runtime wheels too, a few GB; only the CPU is used); onnxruntime,
# onnx and numpy from PyPI. Needs python3 (3.10+) with venv, the Rust toolchain, and
# ../shared/data (the SDD files).
set -euo pipefail
cd "$(git rev-parse --show-toplevel)"

VENV=${PEERS_VENV:-target/peers-venv}
ROUNDS=${ROUNDS:-3}
TRAIN_ROUNDS=${TRAIN_ROUNDS:-1}
TRAIN_EPOCHS=${TRAIN_EPOCHS:-2}
MIN_MS=${MIN_MS:-300}
REPS=${REPS:-5}
MODELS=${MODELS:-"sdd-small sdd-paper"}
TRAIN_CONFIGS=${TRAIN_CONFIGS:-"sdd-tiny sdd-small sdd-paper"}
TRAIN_THREADS=${TRAIN_THREADS:-"1 2"}
OUT_MD=${OUT_MD:-docs/peers.md}
OUT=target/peers
PY=$VENV/bin/python
mkdir -p "$OUT"
RESULTS=$OUT/results.jsonl
: > "$RESULTS"

log() { printf '[bench %s] %s\n' "$(date -u +%H:%M:%S)" "$*" >&2; }
# The 1-minute load average next to the numbers (a shared machine makes them noisy).
load() { printf '{"loadavg": %s}\n' "$(cut -d' ' -f1 /proc/loadavg)" >> "$RESULTS"; }

# 1. Python peers in a virtual environment.
if [ ! -x "$PY" ]; then
    log "creating $VENV"
    python3 -m venv "$VENV"
fi
if ! "$PY" -c "import torch" 2>/dev/null; then
    log "installing torch (CPU wheel index, else PyPI)"
    "$VENV/bin/pip" install --quiet torch --index-url https://download.pytorch.org/whl/cpu \
        || "$VENV/bin/pip" install --quiet torch
fi
if ! "$PY" -c "import onnxruntime, onnx, numpy" 2>/dev/null; then
    log "installing onnxruntime, onnx, numpy"
    "$VENV/bin/pip" install --quiet onnxruntime onnx numpy
fi
"$PY" -c "import torch, onnxruntime, onnx, numpy; print('peers:', 'torch', torch.__version__, 'onnxruntime', onnxruntime.__version__, 'onnx', onnx.__version__, 'numpy', numpy.__version__)" >&2

# 2. The gpecnet side.
log "building gpecnet (release)"
cargo build --release -p gpecnet-trainer --bin gpecnet --example peer_bench >&2
GP=target/release/gpecnet
PB=target/release/examples/peer_bench

export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 RAYON_NUM_THREADS=1

# 3. Export, dump the core's inputs/latents/outputs, check agreement.
CHECKS=()
for m in $MODELS; do
    CHECKS+=("$OUT/check-$m.json")
    if [ "${SKIP_PREP:-0}" = 1 ] && [ -f "$OUT/check-$m.json" ] && [ -f "$OUT/$m-endpoint.onnx" ]; then
        log "$m: reusing the export, dump and check in $OUT (SKIP_PREP=1)"
        continue
    fi
    log "$m: export, dump, check"
    "$GP" onnx --blob "weights/$m.gpec" --out "$OUT/$m.onnx" >/dev/null
    "$GP" onnx --blob "weights/$m.gpec" --out "$OUT/$m-endpoint.onnx" --endpoint-only >/dev/null
    "$PB" dump --blob "weights/$m.gpec" --out "$OUT/$m" >&2
    (cd scripts/peers && "../../$PY" check.py --onnx "../../$OUT/$m.onnx" --dump "../../$OUT/$m" \
        --json-out "../../$OUT/check-$m.json") >&2
done


# 4. Inference, interleaved: per round, per model: gpecnet, onnxruntime, PyTorch.
for r in $(seq 1 "$ROUNDS"); do
    for m in $MODELS; do
        load
        # The whole-test-set call of sdd-paper takes about a minute on the scalar path.
        SET_REPS=$REPS
        [ "$m" = sdd-paper ] && SET_REPS=1
        log "round $r/$ROUNDS $m: gpecnet"
        "$PB" infer --blob "weights/$m.gpec" --min-ms "$MIN_MS" --reps "$REPS" --set-reps "$SET_REPS" >> "$RESULTS"
        log "round $r/$ROUNDS $m: gpecnet batched, SSE2 only"
        "$PB" infer --blob "weights/$m.gpec" --min-ms "$MIN_MS" --reps "$REPS" --set-reps "$SET_REPS" \
            --batched-only --sse2 >> "$RESULTS"
        for peer in ort torch; do
            log "round $r/$ROUNDS $m: $peer"
            (cd scripts/peers && "../../$PY" bench_peer.py --peer "$peer" --onnx "../../$OUT/$m-endpoint.onnx" \
                --dump "../../$OUT/$m" --min-ms "$MIN_MS" --reps "$REPS" --set-reps "$SET_REPS") >> "$RESULTS"
        done
    done
done

# 5. Training epochs, interleaved: per round, per config, per thread count: gpecnet, PyTorch.
for c in $TRAIN_CONFIGS; do
    [ "${SKIP_PREP:-0}" = 1 ] && [ -f "$OUT/train-$c/manifest.json" ] && continue
    "$PB" train-data --config "host-trainer/configs/$c.toml" --out "$OUT/train-$c" >&2
done
for r in $(seq 1 "$TRAIN_ROUNDS"); do
    for c in $TRAIN_CONFIGS; do
        for t in $TRAIN_THREADS; do
            load
            log "train round $r/$TRAIN_ROUNDS $c, $t thread(s): gpecnet"
            OMP_NUM_THREADS=$t RAYON_NUM_THREADS=$t "$PB" train --config "host-trainer/configs/$c.toml" \
                --threads "$t" --epochs "$TRAIN_EPOCHS" >> "$RESULTS"
            log "train round $r/$TRAIN_ROUNDS $c, $t thread(s): torch"
            (cd scripts/peers && OMP_NUM_THREADS=$t "../../$PY" train_torch.py --data "../../$OUT/train-$c" \
                --threads "$t" --epochs "$TRAIN_EPOCHS") >> "$RESULTS"
            if [ "$t" -gt 1 ]; then
                # OpenMP workers that sleep instead of spinning: on a loaded machine the default
                # (spinning) is many times slower at 2 threads than at 1 (docs/peers.md).
                log "train round $r/$TRAIN_ROUNDS $c, $t thread(s): torch, OMP_WAIT_POLICY=PASSIVE"
                (cd scripts/peers && OMP_WAIT_POLICY=PASSIVE OMP_NUM_THREADS=$t "../../$PY" train_torch.py \
                    --data "../../$OUT/train-$c" --threads "$t" --epochs "$TRAIN_EPOCHS" --label torch-passive) >> "$RESULTS"
            fi
        done
    done
done

# 6. The report.
CMD="scripts/peers/bench.sh"
[ "$ROUNDS" != 3 ] && CMD="ROUNDS=$ROUNDS $CMD"
[ "$TRAIN_ROUNDS" != 1 ] && CMD="TRAIN_ROUNDS=$TRAIN_ROUNDS $CMD"
[ "$TRAIN_EPOCHS" != 2 ] && CMD="TRAIN_EPOCHS=$TRAIN_EPOCHS $CMD"
[ "$MODELS" != "sdd-small sdd-paper" ] && CMD="MODELS=\"$MODELS\" $CMD"
[ "$TRAIN_CONFIGS" != "sdd-tiny sdd-small sdd-paper" ] && CMD="TRAIN_CONFIGS=\"$TRAIN_CONFIGS\" $CMD"
[ "${SKIP_PREP:-0}" = 1 ] && CMD="SKIP_PREP=1 $CMD"
README_ARGS=()
[ "$OUT_MD" = docs/peers.md ] && README_ARGS=(--readme README.md)
"$PY" scripts/peers/report.py --results "$RESULTS" --checks "${CHECKS[@]}" --out "$OUT_MD" \
    --command "$CMD" --note "${BENCH_NOTE:-}" "${README_ARGS[@]}"
log "wrote $OUT_MD (raw numbers: $RESULTS)"
