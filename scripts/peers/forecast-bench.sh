#!/usr/bin/env bash
# The shipped defaults' whole forecast (K endpoints, probabilities, point forecast, radii) next
# to onnxruntime, one thread each (not run in CI): gpecnet's scalar Predictor::predict_forecast
# and its batched HostBatchPredictor::predict_forecasts against the ONNX graph `gpecnet onnx`
# writes (its forecast subgraph), on one pedestrian, 16 pedestrians (one drone frame) and the
# whole sdd-m test split; onnxruntime's outputs checked against the core on every window first
# (scripts/peers/forecast.py, 1e-5 m). Interleaved rounds, medians. Writes the section between
# <!-- forecast:begin --> and <!-- forecast:end --> of docs/peers.md and of README.md.
#
#   scripts/peers/forecast-bench.sh                       # about 2 minutes on a 2-core box
#   ROUNDS=1 MODELS=sdd-m-lp scripts/peers/forecast-bench.sh
#
# Environment: ROUNDS (default 3), MODELS (default "sdd-m-lp sdd-m-lp-host"), MIN_MS (300),
# REPS (5), PY (python with onnxruntime, onnx and numpy; default: target/peers-venv's when it
# exists, else python3).
set -euo pipefail
cd "$(git rev-parse --show-toplevel)"
ROUNDS=${ROUNDS:-3}
MODELS=${MODELS:-"sdd-m-lp sdd-m-lp-host"}
MIN_MS=${MIN_MS:-300}
REPS=${REPS:-5}
PY=${PY:-$( [ -x target/peers-venv/bin/python ] && echo target/peers-venv/bin/python || echo python3 )}
# An absolute path (the python step runs in scripts/peers): a file as given, else the command.
if [ -e "$PY" ]; then PY=$(realpath "$PY"); else PY=$(command -v "$PY" || echo "$PY"); fi
OUT=target/peers
mkdir -p "$OUT"
RESULTS=$OUT/forecast.jsonl
: > "$RESULTS"
log() { printf '[forecast-bench %s] %s\n' "$(date -u +%H:%M:%S)" "$*" >&2; }
"$PY" -c "import onnxruntime, onnx, numpy" 2>/dev/null || {
    echo "forecast-bench: $PY lacks onnxruntime/onnx/numpy: pip install onnxruntime onnx numpy (or run scripts/peers/bench.sh once, which makes target/peers-venv)" >&2
    exit 2
}
export OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
log "building gpecnet (release)"
cargo build --release -p gpecnet-trainer --bin gpecnet --example peer_bench >&2
for m in $MODELS; do
    target/release/gpecnet onnx --blob "weights/$m.gpec" --out "$OUT/$m.onnx" >/dev/null
done
for r in $(seq 1 "$ROUNDS"); do
    for m in $MODELS; do
        printf '{"loadavg": %s}\n' "$(cut -d' ' -f1 /proc/loadavg)" >> "$RESULTS"
        log "round $r/$ROUNDS $m: gpecnet (scalar, batched), then onnxruntime"
        target/release/examples/peer_bench forecast --blob "weights/$m.gpec" --out "$OUT/fc-$m" \
            --min-ms "$MIN_MS" --reps "$REPS" >> "$RESULTS"
        # onnxruntime sums with fused multiply-adds in its own order: within 1e-5 m of the
        # core for the MCU-sized default; the host model's 64-wide layers round more (5e-5 m).
        tol=1e-5
        [ "$m" = sdd-m-lp-host ] && tol=5e-5
        (cd scripts/peers && "$PY" forecast.py --onnx "../../$OUT/$m.onnx" --dump "../../$OUT/fc-$m" \
            --tol "$tol" --min-ms "$MIN_MS" --reps "$REPS") >> "$RESULTS"
    done
done
"$PY" scripts/peers/forecast_report.py --results "$RESULTS" --rounds "$ROUNDS" \
    --command "scripts/peers/forecast-bench.sh" --doc docs/peers.md --readme README.md
