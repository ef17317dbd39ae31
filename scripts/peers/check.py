#!/usr/bin/env python3
"""onnxruntime (and PyTorch eager, when installed) against gpecnet-core on the same inputs.

    python scripts/peers/check.py --onnx target/peers/sdd-small.onnx --dump target/peers/sdd-small

The dump (`cargo run --release -p gpecnet-trainer --example peer_bench -- dump ...`) holds the
core's network inputs x, latents z and predictor positions pos for every SDD test window
(K = 20, seed = window index) and test window 0 at K = 1000, plus the core's outputs in pixels.
The peers run the exported graph on exactly those inputs; their outputs are mapped to pixels
like the core maps its own (Frame::output, in float64 here) and compared coordinate by
coordinate. Prints the max abs difference in px per output and exits 1 when any exceeds
--tol (default 0.01 px). Peers sum in their own order with fused multiply-adds and their own
sin, so they agree within rounding, not bit for bit.
"""

import argparse
import json
import sys

import numpy as np

import peers


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--onnx", required=True)
    ap.add_argument("--dump", required=True)
    ap.add_argument("--tol", type=float, default=0.01, help="max abs difference allowed, px")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--json-out", help="also write the JSON object to this file")
    a = ap.parse_args()

    import onnx

    onnx.checker.check_model(onnx.load(a.onnx), full_check=True)
    man, arr = peers.load_dump(a.dump)
    scale = man["data_scale"]
    o, r = arr["origin"], arr["rot"]
    feeds = {"x": arr["x"], "z": arr["z"]}
    sess = peers.ort_session(a.onnx)
    names = {i.name for i in sess.get_inputs()}
    if "pos" in names:
        feeds["pos"] = arr["pos"]
    outs = dict(zip([x.name for x in sess.get_outputs()], sess.run(None, feeds)))
    ped = dict(zip([x.name for x in sess.get_outputs()],
                   sess.run(None, {k: (arr["ped_z"] if k == "z" else v[:1])
                                   for k, v in feeds.items()})))

    def compare(prefix, outs):
        res = {}
        e = peers.to_px(outs["d"], o, r, scale)
        res["endpoints (test set, K = 20)"] = np.abs(e - arr["core_endpoints"]).max()
        ep = peers.to_px(ped["d"], o[:1], r[:1], scale) if prefix == "ort" else None
        if ep is not None:
            res["endpoints (one pedestrian, K = 1000)"] = np.abs(
                ep - arr["ped_core_endpoints"]).max()
        if "point" in outs and "core_point" in arr:
            n = outs["point"].shape[0]
            p = peers.to_px(outs["point"].reshape(n, -1, 2), o, r, scale)
            res["point forecast (test set)"] = np.abs(p - arr["core_point"]).max()
        if "traj" in outs and "core_traj" in arr:
            n, k = outs["traj"].shape[:2]
            t = peers.to_px(outs["traj"].reshape(n, k, -1, 2), o, r, scale)
            res["trajectories (test set, K = 20, 11 points)"] = np.abs(
                t - arr["core_traj"][:, :, :-1, :]).max()
        return {k: float(v) for k, v in res.items()}

    report = {"model": man["model"], "tol_px": a.tol, "onnxruntime": compare("ort", outs)}
    try:
        import torch

        torch.set_num_threads(1)
        net, _ = peers.torch_model(a.onnx)
        with torch.no_grad():
            t = net(*(torch.from_numpy(feeds[k]) for k in ("x", "z", "pos") if k in feeds))
        report["pytorch"] = compare("torch", {k: v.numpy() for k, v in t.items()})
    except ImportError:
        pass
    worst = max(v for peer in ("onnxruntime", "pytorch") for v in report.get(peer, {}).values())
    report["max_abs_diff_px"] = worst
    report["ok"] = worst <= a.tol
    if a.json_out:
        with open(a.json_out, "w") as f:
            json.dump(report, f)
    if a.json:
        print(json.dumps(report))
    else:
        print(f"{man['model']}: max abs difference to gpecnet-core, px (tolerance {a.tol})")
        for peer in ("onnxruntime", "pytorch"):
            for k, v in report.get(peer, {}).items():
                print(f"  {peer:<12} {k:<45} {v:.3e}")
        print("OK" if report["ok"] else "FAILED")
    return 0 if report["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
