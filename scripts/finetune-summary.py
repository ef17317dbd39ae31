#!/usr/bin/env python3
"""Tabulates scripts/finetune-runs.sh's JSON (docs/own-data.md, "Fine-tuning").

Usage: scripts/finetune-summary.py [DIR]   (default target/finetune/runs/json)
Per ETH/UCY scene and training fraction: the shipped model zero-shot, fine-tuned from it and
trained from scratch, each on that scene's test split (K = 20, f32 blobs with the refitted
proposal and scores), mean ± std over the seeds found, and whether fine-tuning beats both
others on minFDE by more than the seed spread.
"""
import os
import statistics
import sys

from studylib import load_json

d = sys.argv[1] if len(sys.argv) > 1 else "target/finetune/runs/json"
scenes = ["eth", "hotel", "univ", "zara1", "zara2"]


def load(name):
    return load_json(os.path.join(d, name + ".json"))


def stats(vals):
    if not vals:
        return None
    m = statistics.mean(vals)
    s = statistics.stdev(vals) if len(vals) > 1 else 0.0
    return m, s


def fmt(st):
    if st is None:
        return "–"
    return f"{st[0]:.3f} ± {st[1]:.3f}"


print("| scene | data | zero-shot minADE / minFDE / point FDE | fine-tuned (seeds) | from scratch (seeds) | fine-tuning beats both (minFDE) |")
print("|---|---|---|---|---|---|")
wins = {}
avg = {}
for pct in ["10", "100"]:
    for sc in scenes:
        z = load(f"{sc}-zeroshot")
        if z is None:
            continue
        cells = {}
        for method in ["ft", "scratch"]:
            runs = [load(f"{sc}-{method}-f{pct}-s{s}") for s in (1, 2, 3)]
            runs = [r for r in runs if r is not None]
            cells[method] = (
                len(runs),
                stats([r["min_ade"] for r in runs]),
                stats([r["min_fde"] for r in runs]),
                stats([r["point_fde"] for r in runs]),
            )
        (nf, fa, ff, fp), (ns, sa, sf, sp) = cells["ft"], cells["scratch"]
        if nf == 0 and ns == 0:
            continue
        verdict = "–"
        if ff and sf and min(nf, ns) < 2:
            lower = ff[0] < sf[0] and ff[0] < z["min_fde"]
            verdict = ("lower than both" if lower else "not lower than both") + " (1 seed: no spread)"
        elif ff and sf:
            spread = max(ff[1], sf[1])
            beats_scratch = ff[0] + spread < sf[0]
            beats_zero = ff[0] + ff[1] < z["min_fde"]
            verdict = "yes" if beats_scratch and beats_zero else (
                "no (" + ", ".join(
                    w for w, b in [("scratch", beats_scratch), ("zero-shot", beats_zero)] if not b
                ) + " not beaten)"
            )
            wins.setdefault(pct, []).append(verdict == "yes")
        # ETH/UCY averages (per method, over the scenes with runs).
        avg.setdefault(pct, {"zero-shot": [], "ft": [], "scratch": []})
        avg[pct]["zero-shot"].append(z["min_fde"])
        if ff:
            avg[pct]["ft"].append(ff[0])
        if sf:
            avg[pct]["scratch"].append(sf[0])
        print(
            f"| {sc} | {pct} % | {z['min_ade']:.3f} / {z['min_fde']:.3f} / {z['point_fde']:.3f} | "
            f"{fmt(fa)} / {fmt(ff)} / {fmt(fp)} ({nf}) | {fmt(sa)} / {fmt(sf)} / {fmt(sp)} ({ns}) | {verdict} |"
        )
for pct, w in wins.items():
    print(f"\n{pct} %: fine-tuning beats both beyond the seed spread on {sum(w)} of {len(w)} scenes")
for pct, a in avg.items():
    if all(len(v) == 5 for v in a.values()):
        print(
            f"{pct} %: ETH/UCY average minFDE zero-shot {sum(a['zero-shot']) / 5:.3f}, "
            f"fine-tuned {sum(a['ft']) / 5:.3f}, from scratch {sum(a['scratch']) / 5:.3f} m"
        )
