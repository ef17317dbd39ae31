#!/usr/bin/env python3
"""Chooses the online loop's settings on VALIDATION recordings only (docs/online.md).

Streams the validation splits of ETH/UCY (eth_ucy:hotel's val/: the val part of every other
sequence) and SDD in metres (the five held-out training scenes) through `gpecnet stream --json`
for every setting of the grid, and counts, per setting, the goals of docs/online.md that a
recording with at least MIN_N scored forecasts misses (loop on). Prints the settings ranked.

    python3 scripts/online-sweep.py [--bin target/debug/gpecnet] [--blob weights/sdd-m-lp-qe.gpec]
"""
import argparse
import itertools
import json
import subprocess
import sys

MIN_N = 300
SETS = ["eth_ucy:hotel", "sdd-m"]


def violations(rep):
    """Goal misses of one loop-on report, and a deviation score for ties."""
    miss, dev = [], 0.0
    e = rep["endpoint"]
    if not 0.87 <= e["r90"] <= 0.93:
        miss.append(f"r90 {e['r90']:.3f}")
    dev += abs(e["r90"] - 0.90)
    if not 0.45 <= e["r50"] <= 0.55:
        miss.append(f"r50 {e['r50']:.3f}")
    dev += abs(e["r50"] - 0.50)
    ph = [c["r90"] for c in rep["per_horizon"]]
    if min(ph) < 0.85 or max(ph) > 0.95:
        miss.append(f"horizons {min(ph):.3f}-{max(ph):.3f}")
    st = rep["by_motion"]["standing"]
    if st["n"] >= 30 and st["r90"] < 0.85:
        miss.append(f"standing {st['r90']:.3f}")
    ratio = rep["mean_r90"] / max(rep["oracle_r90"], 1e-9)
    if ratio > 1.10:
        miss.append(f"width {ratio:.2f}x oracle")
    dev += max(0.0, ratio - 1.0)
    f = rep["fde"]
    best = min([x for x in [f["head"]] + f["cv"] if x is not None])
    if f["point"] > 1.01 * best:
        miss.append(f"point {f['point'] / best:.3f}x best")
    dev += max(0.0, f["point"] / best - 1.0)
    return miss, dev


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="target/debug/gpecnet")
    ap.add_argument("--blob", default="weights/sdd-m-lp-qe.gpec")
    ap.add_argument("--out", default=None, help="write every row as JSON lines")
    ap.add_argument("--grid", default=None, help="a JSON object replacing the grid below")
    a = ap.parse_args()
    # The second grid of docs/online.md (the first: gamma 0.05-0.3, eta 2 and 8, forgetting
    # 0.95 and 0.99, expert_prior 0.5 and 2, with and without bins, pending 2 and 12).
    grid = {
        "pending": [2, 12],
        "gamma": [0.05, 0.1, 0.2],
        "eta": [2.0, 8.0, 20.0],
        "forgetting": [0.99, 0.999],
        "expert_prior": [0.5],
        "bins": [True, False],
    }
    if a.grid:
        grid = json.loads(a.grid)
    rows = []
    for vals in itertools.product(*grid.values()):
        s = dict(zip(grid.keys(), vals))
        misses, dev, n = [], 0.0, 0
        for ds in SETS:
            cmd = [a.bin, "stream", "--blob", a.blob, "--dataset", ds, "--split", "val", "--json",
                   "--pending", str(s["pending"]), "--gamma", str(s["gamma"]), "--eta", str(s["eta"]),
                   "--forgetting", str(s["forgetting"]), "--expert-prior", str(s["expert_prior"])]
            if s["bins"]:
                cmd.append("--motion-bins")
            out = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
            for pair in out["recordings"]:
                on = pair[1]
                if on["scored"] < MIN_N:
                    continue
                m, d = violations(on)
                misses += [f"{on['scene']}: {x}" for x in m]
                dev += d
                n += 1
        rows.append((len(misses), dev / max(n, 1), s, misses))
        print(f"{len(misses):3d} {dev / max(n, 1):.4f} {s}", file=sys.stderr, flush=True)
    rows.sort(key=lambda r: (r[0], r[1]))
    if a.out:
        with open(a.out, "w") as f:
            for r in rows:
                f.write(json.dumps({"misses": r[0], "deviation": r[1], "settings": r[2], "which": r[3]}) + "\n")
    for r in rows[:10]:
        print(f"{r[0]:3d} misses, deviation {r[1]:.4f}: {r[2]}\n      {'; '.join(r[3])}")


if __name__ == "__main__":
    main()
