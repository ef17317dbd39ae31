"""Shared helpers of the peer scripts: the dumps of `peer_bench dump`, the ONNX model run by
onnxruntime, and the same graph rebuilt as a PyTorch module from the ONNX initializers.

The ONNX graph is the one `gpecnet onnx` writes (host-trainer/onnx/src/lib.rs): inputs x [n, 2P],
z [n, k, zdim], pos [n, 2] (with a trajectory predictor); outputs d [n, k, 2], point
[n, 2F] (point head), traj [n, k, 2(F-1)] (predictor); every dense layer is
MatMul(input, W^T) + b then Sin/Relu; the first layer of the decoder and of the predictor is
split by input columns (initializers <net>.0.weight.<part>).
"""

import json
import os
import re
import time

import numpy as np


def load_dump(folder):
    """The manifest and arrays of a `peer_bench dump` / `train-data` folder."""
    with open(os.path.join(folder, "manifest.json")) as f:
        man = json.load(f)
    arrays = {}
    for name, a in man["arrays"].items():
        arrays[name] = np.fromfile(os.path.join(folder, a["file"]), dtype="<f4").reshape(
            a["shape"]
        )
    return man, arrays


def to_px(d, origin, rot, data_scale):
    """Network-frame points d [n, ..., 2] in pixels (gpecnet_core::frame::Frame::output),
    in float64: u = d / data_scale, rotated by (c, s), plus the origin."""
    d = d.astype(np.float64)
    shape = (d.shape[0],) + (1,) * (d.ndim - 2) + (2,)
    o = origin.astype(np.float64).reshape(shape)
    r = rot.astype(np.float64).reshape(shape)
    u = d / float(data_scale)
    c, s = r[..., 0], r[..., 1]
    x = c * u[..., 0] - s * u[..., 1] + o[..., 0]
    y = s * u[..., 0] + c * u[..., 1] + o[..., 1]
    return np.stack([x, y], axis=-1)


def ort_session(path, threads=1):
    """An onnxruntime CPU session with `threads` intra-op threads (and one inter-op thread)."""
    import onnxruntime as ort

    so = ort.SessionOptions()
    so.intra_op_num_threads = threads
    so.inter_op_num_threads = 1
    so.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    so.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    return ort.InferenceSession(path, so, providers=["CPUExecutionProvider"])


def onnx_layers(path):
    """{net: [layer dicts]} from the ONNX initializers: each layer has 'w' (W^T, or a dict of
    column parts for a split first layer), 'b', and 'act' ('sin', 'relu' or None)."""
    import onnx
    from onnx import numpy_helper

    m = onnx.load(path)
    init = {t.name: numpy_helper.to_array(t) for t in m.graph.initializer}
    acts = {}
    for node in m.graph.node:
        if node.op_type in ("Sin", "Relu", "Identity"):
            mm = re.match(r"^(\w+)\.(\d+)\.pre$", node.input[0])
            if mm:
                acts[(mm.group(1), int(mm.group(2)))] = {
                    "Sin": "sin",
                    "Relu": "relu",
                    "Identity": None,
                }[node.op_type]
    nets = {}
    for name, arr in init.items():
        mm = re.match(r"^(\w+)\.(\d+)\.(weight|bias)(?:\.(\w+))?$", name)
        if not mm:
            continue
        net, i, kind, part = mm.group(1), int(mm.group(2)), mm.group(3), mm.group(4)
        layers = nets.setdefault(net, {})
        layer = layers.setdefault(i, {"act": acts.get((net, i))})
        if kind == "bias":
            layer["b"] = arr
        elif part is None:
            layer["w"] = arr
        else:
            layer.setdefault("w", {})[part] = arr
    meta = {p.key: p.value for p in m.metadata_props}
    return {k: [v[i] for i in sorted(v)] for k, v in nets.items()}, meta


def torch_model(path):
    """The ONNX graph as a PyTorch eager module (float32), same weights, same split."""
    import torch

    nets, meta = onnx_layers(path)

    def act(h, a):
        if a == "sin":
            return torch.sin(h)
        if a == "relu":
            return torch.relu(h)
        return h

    class Net(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.p = {}
            for net, layers in nets.items():
                for i, l in enumerate(layers):
                    if isinstance(l["w"], dict):
                        for part, w in l["w"].items():
                            self.p[f"{net}.{i}.w.{part}"] = torch.from_numpy(w.copy())
                    else:
                        self.p[f"{net}.{i}.w"] = torch.from_numpy(l["w"].copy())
                    self.p[f"{net}.{i}.b"] = torch.from_numpy(l["b"].copy())
            self.nets = nets

        def chain(self, net, h, start=0):
            layers = self.nets[net]
            for i in range(start, len(layers)):
                h = act(torch.matmul(h, self.p[f"{net}.{i}.w"]) + self.p[f"{net}.{i}.b"],
                        layers[i]["act"])
            return h

        def forward(self, x, z, pos=None):
            f = self.chain("encoder_past", x)
            l0 = self.nets["decoder"][0]
            win = torch.matmul(f, self.p["decoder.0.w.f"]) + self.p["decoder.0.b"]
            h = act(torch.matmul(z, self.p["decoder.0.w.z"]) + win.unsqueeze(1), l0["act"])
            d = self.chain("decoder", h, 1)
            out = {"d": d}
            if "point_head" in self.nets:
                out["point"] = self.chain("point_head", x)
            if "predictor" in self.nets and pos is not None:
                g = self.chain("encoder_dest", d)
                p0 = self.nets["predictor"][0]
                win = (torch.matmul(f, self.p["predictor.0.w.f"])
                       + torch.matmul(pos, self.p["predictor.0.w.pos"])
                       + self.p["predictor.0.b"])
                h = act(torch.matmul(g, self.p["predictor.0.w.g"]) + win.unsqueeze(1),
                        p0["act"])
                out["traj"] = self.chain("predictor", h, 1)
            return out

    return Net(), meta


def time_case(fn, min_s=0.3, reps=5):
    """Median seconds per call: `reps` repetitions, each calling fn until min_s have passed.
    The first call warms up; when it alone took min_s or more it counts as the first
    repetition (as peer_bench's time_case)."""
    t0 = time.perf_counter()
    fn()
    first = time.perf_counter() - t0
    per = [first] if first >= min_s else []
    while len(per) < max(1, reps):
        t0, calls = time.perf_counter(), 0
        while calls == 0 or time.perf_counter() - t0 < min_s:
            fn()
            calls += 1
        per.append((time.perf_counter() - t0) / calls)
    per.sort()
    return per[len(per) // 2]
