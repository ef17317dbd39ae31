#!/usr/bin/env python3
"""The whole forecast of a proposal model (K endpoints, probabilities, point forecast, radii)
through onnxruntime against gpecnet-core: agreement on every test window, then the time of
the cases `peer_bench forecast` times for the core, one thread.

    target/release/gpecnet onnx --blob weights/sdd-m-lp.gpec --out target/peers/sdd-m-lp.onnx
    cargo run --release -p gpecnet-trainer --example peer_bench -- \
        forecast --blob weights/sdd-m-lp.gpec --out target/peers/fc-sdd-m-lp
    python scripts/peers/forecast.py --onnx target/peers/sdd-m-lp.onnx --dump target/peers/fc-sdd-m-lp

The graph `gpecnet onnx` writes for a proposal model also has the trajectory predictor's
`traj` output, which `Predictor::predict_forecast` does not compute: the forecast's subgraph
(x -> d, point, prob, radii) is extracted first (onnx.utils.Extractor), so both sides compute
the same thing. Cases: one pedestrian (test window 0, x [1, 16]); 16 pedestrians in one call
(windows 0-15, what one drone frame holds); the whole test split in one call. Agreement:
every endpoint, the point forecast's endpoint (mapped to the blob's unit as the core maps
them) and the radii within --tol of the blob's unit (default 1e-5), the probabilities within
--tol. Prints one JSON object; exits 1 when the agreement fails.
"""

import argparse
import json
import os
import sys
import tempfile

import numpy as np

import peers


def forecast_graph(path):
    """The subgraph of `path` from x to the forecast's outputs (no trajectory predictor),
    written to a temporary file; its path and output names."""
    import onnx
    from onnx.utils import Extractor

    m = onnx.load(path)
    names = [o.name for o in m.graph.output]
    outs = [n for n in ("d", "point", "prob", "radii") if n in names]
    sub = Extractor(m).extract_model(["x"], outs)
    sub.metadata_props.extend(m.metadata_props)
    fd, tmp = tempfile.mkstemp(suffix=".onnx")
    os.close(fd)
    onnx.save(sub, tmp)
    onnx.checker.check_model(tmp, full_check=True)
    return tmp, outs


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--onnx", required=True, help="gpecnet onnx of a proposal model")
    ap.add_argument("--dump", required=True, help="peer_bench forecast --out folder")
    ap.add_argument("--tol", type=float, default=1e-5, help="max abs difference, blob unit")
    ap.add_argument("--min-ms", type=float, default=300)
    ap.add_argument("--reps", type=int, default=5)
    a = ap.parse_args()
    import onnxruntime as ort

    man, arr = peers.load_dump(a.dump)
    graph, outs = forecast_graph(a.onnx)
    try:
        sess = peers.ort_session(graph, threads=1)
        x = arr["x"]
        got = dict(zip(outs, sess.run(outs, {"x": x})))
        o, r, scale = arr["origin"], arr["rot"], man["data_scale"]
        diff = {
            "endpoints": np.abs(peers.to_px(got["d"], o, r, scale) - arr["core_endpoints"]).max(),
        }
        if "point" in got:
            n = x.shape[0]
            pt = peers.to_px(got["point"].reshape(n, -1, 2), o, r, scale)[:, -1, :]
            diff["point forecast's endpoint"] = np.abs(pt - arr["core_point_end"]).max()
        if "prob" in got:
            diff["probabilities"] = np.abs(got["prob"] - arr["core_prob"]).max()
        if "radii" in got:
            diff["radii r50, r90"] = np.abs(got["radii"] - arr["core_radii"]).max()
        diff = {k: float(v) for k, v in diff.items()}
        worst = max(diff.values())
        crowd = man["crowd"]
        cases = {"ped": x[:1].copy(), f"crowd{crowd}": x[:crowd].copy(), "set": x}
        times = {
            name: peers.time_case(lambda cx=cx: sess.run(outs, {"x": cx}), a.min_ms / 1e3, a.reps)
            for name, cx in cases.items()
        }
    finally:
        os.unlink(graph)
    report = {
        "impl": "ort",
        "version": f"onnxruntime {ort.__version__}",
        "model": man["model"],
        "dataset": man["dataset"],
        "unit": man["unit"],
        "n_windows": int(x.shape[0]),
        "outputs": outs,
        "max_abs_diff": diff,
        "tol": a.tol,
        "ok": worst <= a.tol,
        "threads": 1,
        "seconds_per_call": times,
    }
    print(json.dumps(report))
    return 0 if report["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
