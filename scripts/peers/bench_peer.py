#!/usr/bin/env python3
"""Times one peer (onnxruntime or PyTorch eager) on the cases `peer_bench infer` times for
gpecnet-core, one thread, fed the core's own inputs and latents from a `peer_bench dump`.

    python scripts/peers/bench_peer.py --peer ort --onnx target/peers/sdd-small-endpoint.onnx \
        --dump target/peers/sdd-small

Cases (endpoint path only, as `Predictor::predict_samples` computes it):
  ped_k{1,20,200,1000}: test window 0, its first K latents (x [1, 16], z [1, K, zdim]);
  set_k20: the whole SDD test set in one call (x [2829, 16], z [2829, 20, zdim]).
Prints one JSON object: median seconds per call per case.
"""

import argparse
import json
import os
import sys

import peers


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--peer", choices=["ort", "torch"], required=True)
    ap.add_argument("--onnx", required=True, help="endpoint-only ONNX (gpecnet onnx --endpoint-only)")
    ap.add_argument("--dump", required=True)
    ap.add_argument("--min-ms", type=float, default=300)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--set-reps", type=int, default=None, help="repetitions of set_k20")
    a = ap.parse_args()
    man, arr = peers.load_dump(a.dump)
    x, z, pz = arr["x"], arr["z"], arr["ped_z"]
    cases = {f"ped_k{k}": (x[:1].copy(), pz[:, :k].copy()) for k in man["ped_ks"]}
    cases[f"set_k{man['k']}"] = (x, z)
    out = {}

    def reps(name):
        return a.set_reps if name.startswith("set_") and a.set_reps else a.reps

    if a.peer == "ort":
        import onnxruntime as ort

        sess = peers.ort_session(a.onnx, threads=1)
        version = f"onnxruntime {ort.__version__}"
        for name, (cx, cz) in cases.items():
            feeds = {"x": cx, "z": cz}
            out[name] = peers.time_case(lambda: sess.run(["d"], feeds), a.min_ms / 1e3,
                                        reps(name))
    else:
        import torch

        torch.set_num_threads(1)
        torch.set_num_interop_threads(1)
        net, _ = peers.torch_model(a.onnx)
        version = f"torch {torch.__version__}"
        for name, (cx, cz) in cases.items():
            tx, tz = torch.from_numpy(cx), torch.from_numpy(cz)

            def run():
                with torch.no_grad():
                    return net(tx, tz)["d"]

            out[name] = peers.time_case(run, a.min_ms / 1e3, reps(name))
    print(json.dumps({
        "impl": a.peer,
        "version": version,
        "model": man["model"],
        "threads": 1,
        "omp_num_threads": os.environ.get("OMP_NUM_THREADS"),
        "seconds_per_call": out,
    }))
    return 0


if __name__ == "__main__":
    sys.exit(main())
