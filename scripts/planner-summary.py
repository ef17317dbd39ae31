#!/usr/bin/env python3
"""Validation table of the endpoint probabilities (docs/planner.md): one row per metric,
mean ± sample std over the score fits given (default runs/score/h8-s0..2/score.json, made by
scripts/planner-runs.sh). Validation only: the fits never read the test set."""
import json
import statistics
import sys

paths = sys.argv[1:] or [f"runs/score/h8-s{s}/score.json" for s in range(3)]
fits = [json.load(open(p)) for p in paths]
rows = [
    ("P(most probable = closest)", lambda v: v["top_is_closest"], 3),
    ("ECE, all probabilities (15 bins)", lambda v: v["ece"], 4),
    ("ECE, top-label", lambda v: v["top_ece"], 4),
    ("mixture NLL (nats, m)", lambda v: v["mixture_nll"], 3),
    ("equal-weight NLL (nats, m)", lambda v: v["uniform_nll"], 3),
    ("NLL gain of the probabilities (nats)", lambda v: v["mixture_nll"] - v["uniform_nll"], 3),
    ("brier-minFDE (m)", lambda v: v["brier_min_fde"], 4),
    ("FDE of the most probable endpoint (m)", lambda v: v["top_fde"], 4),
    ("FDE of the probability-weighted mean (m)", lambda v: v["weighted_fde"], 4),
    ("FDE of the point forecast (m)", lambda v: v["point_fde"], 4),
    ("r50 / r90 coverage (calibrated here)", lambda v: v["r50_coverage"], 3),
    ("r90 coverage", lambda v: v["r90_coverage"], 3),
]
print(f"| metric (validation, {fits[0]['val']['n']} windows) | " + " | ".join(p.split('/')[-2] for p in paths) + " | mean ± std |")
print("|---|" + "---|" * (len(paths) + 1))
for name, f, d in rows:
    vals = [f(x["val"]) for x in fits]
    sd = statistics.stdev(vals) if len(vals) > 1 else 0.0
    print(f"| {name} | " + " | ".join(f"{v:.{d}f}" for v in vals) + f" | {statistics.mean(vals):.{d}f} ± {sd:.{d}f} |")
print(f"| radius multipliers c50 / c90 | " + " | ".join(f"{x['radius_scales'][0]:.3f} / {x['radius_scales'][1]:.3f}" for x in fits) + " | – |")
print(f"| L2, inverse temperature | " + " | ".join(f"{x['l2']}, {x['inverse_temperature']:.3f}" for x in fits) + " | – |")
