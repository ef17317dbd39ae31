#!/usr/bin/env python3
"""One G-PECNet training epoch in PyTorch eager: the trainer's architecture, loss, batch size
and Adam (host-trainer/train/src/model.rs, train/trainer.rs, optim.rs), on the trainer's own
training samples (`peer_bench train-data`), for the side-by-side benchmark.

    python scripts/peers/train_torch.py --data target/peers/train-sdd-small --threads 1

Same per batch as `Trainer::train_epoch`: shuffle, batches of `batch_size`, eps ~ N(0, 1)
[B, zdim], forward (encoder_past, encoder_dest, encoder_latent -> mu, logvar, z = mu +
exp(logvar / 2) eps, decoder on [f, z], predictor on [f, encoder_dest(dest_recon),
initial_pos]), loss = MSE(dest) + kld_reg KLD + adl_reg MSE(future) (+ point_reg point loss
with a point head), backward, torch.optim.Adam step (PyTorch defaults, the trainer's lr), and
the loss read back as a Python float (the trainer reads it every batch too). Every MLP is
Linear -> sin(w0 .) -> ... -> Linear with the trainer's input/output scales (coord_scale).
Prints one JSON object: every timed epoch's seconds and their median (one warm-up first).
"""

import argparse
import json
import math
import sys
import time

import numpy as np
import torch

import peers


class Mlp(torch.nn.Module):
    def __init__(self, n_in, hidden, n_out, act, w0, in_scale=1.0, out_scale=1.0):
        super().__init__()
        dims = [n_in] + list(hidden) + [n_out]
        self.layers = torch.nn.ModuleList(
            torch.nn.Linear(a, b) for a, b in zip(dims[:-1], dims[1:])
        )
        with torch.no_grad():  # SIREN init, as Mlp::new
            for i, l in enumerate(self.layers):
                n = l.in_features
                if act == "sine":
                    wb = 1.0 / n if i == 0 else math.sqrt(6.0 / n) / w0
                else:
                    wb = 1.0 / math.sqrt(n)
                l.weight.uniform_(-wb, wb)
                l.bias.uniform_(-1.0 / math.sqrt(n), 1.0 / math.sqrt(n))
        self.act, self.w0 = act, w0
        self.in_scale, self.out_scale = in_scale, out_scale

    def forward(self, x):
        h = x * (1.0 / self.in_scale) if self.in_scale != 1.0 else x
        last = len(self.layers) - 1
        for i, l in enumerate(self.layers):
            h = l(h)
            if i < last:
                h = torch.sin(h * self.w0) if self.act == "sine" else torch.relu(h)
        return h * self.out_scale if self.out_scale != 1.0 else h


class GPecNet(torch.nn.Module):
    def __init__(self, c, past, future):
        super().__init__()
        a, w0, cs = c["activation"], c["w0"], c["coord_scale"]
        fdim, zdim = c["fdim"], c["zdim"]
        self.zdim = zdim
        self.encoder_past = Mlp(2 * past, c["enc_past_size"], fdim, a, w0, cs, 1.0)
        self.encoder_dest = Mlp(2, c["enc_dest_size"], fdim, a, w0, cs, 1.0)
        self.encoder_latent = Mlp(2 * fdim, c["enc_latent_size"], 2 * zdim, a, w0)
        self.decoder = Mlp(fdim + zdim, c["dec_size"], 2, a, w0, 1.0, cs)
        self.predictor = Mlp(2 * fdim + 2, c["predictor_hidden_size"], 2 * (future - 1),
                             a, w0, 1.0, cs)
        ph = c.get("point_head_size") or []
        self.point_head = Mlp(2 * past, ph, 2 * future, a, w0, cs, cs) if ph else None
        self.kld_reg, self.adl_reg = c["kld_reg"], c["adl_reg"]
        self.point_reg = c.get("point_reg", 1.0)
        self.future = future

    def loss(self, obs, dest, fut, init, eps):
        f = self.encoder_past(obs)
        df = self.encoder_dest(dest)
        lat = self.encoder_latent(torch.cat([f, df], 1))
        mu, logvar = lat[:, : self.zdim], lat[:, self.zdim:]
        z = mu + torch.exp(0.5 * logvar) * eps
        recon = self.decoder(torch.cat([f, z], 1))
        pred = self.predictor(torch.cat([f, self.encoder_dest(recon), init], 1))
        rcl = ((dest - recon) ** 2).mean()
        adl = ((fut - pred) ** 2).mean()
        kld = -0.5 * (1 + logvar - mu**2 - torch.exp(logvar)).sum()
        total = rcl + self.kld_reg * kld + self.adl_reg * adl
        if self.point_head is not None:
            b = obs.shape[0]
            p = self.point_head(obs).reshape(b, self.future, 2)
            truth = torch.cat([fut, dest], 1).reshape(b, self.future, 2)
            dist = torch.sqrt(((p - truth) ** 2).sum(2) + 1e-4)
            total = total + self.point_reg * (dist.mean() + dist[:, -1].mean())
        return total


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="folder written by peer_bench train-data")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--epochs", type=int, default=2, help="timed epochs (after one warm-up)")
    ap.add_argument("--label", default="torch", help="impl name in the JSON")
    a = ap.parse_args()
    torch.set_num_threads(a.threads)
    torch.manual_seed(1)
    man, arr = peers.load_dump(a.data)
    c = man["cfg"]
    obs, dest, fut, init = (torch.from_numpy(arr[k].copy())
                            for k in ("obs", "dest", "future", "initial_pos"))
    past, future = obs.shape[1] // 2, fut.shape[1] // 2 + 1
    model = GPecNet(c, past, future)
    opt = torch.optim.Adam(model.parameters(), lr=c["learning_rate"])
    n, bs = obs.shape[0], c["batch_size"]

    def epoch():
        perm = torch.randperm(n)
        for s in range(0, n, bs):
            idx = perm[s: s + bs]
            eps = torch.randn(idx.shape[0], model.zdim)
            loss = model.loss(obs[idx], dest[idx], fut[idx], init[idx], eps)
            opt.zero_grad()
            loss.backward()
            opt.step()
            if not math.isfinite(loss.item()):
                raise SystemExit("diverged")

    epoch()
    times = []
    for _ in range(max(1, a.epochs)):
        t0 = time.perf_counter()
        epoch()
        times.append(time.perf_counter() - t0)
    print(json.dumps({
        "impl": a.label,
        "omp_wait_policy": __import__("os").environ.get("OMP_WAIT_POLICY"),
        "version": f"torch {torch.__version__}",
        "config": man["config"],
        "threads": a.threads,
        "n_train": int(n),
        "batch_size": bs,
        "epoch_seconds": times,
        "median": float(np.median(times)),
    }))
    return 0


if __name__ == "__main__":
    sys.exit(main())
