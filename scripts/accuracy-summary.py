#!/usr/bin/env python3
"""Summarise accuracy-study runs (docs/accuracy.md): for every run folder under runs/acc/
matching the prefixes given, the best validation epoch of the CVAE (min FDE, K = 20) and of the
point head (FDE, K = 1), then mean ± std over the seeds of each variant.

Usage: scripts/accuracy-summary.py [--epochs N] [PREFIX ...]   (default: every run, all epochs)
--epochs N: only the first N epochs of each run's history (a run extended to 600 epochs
still reports its 300-epoch result).
"""
import glob, json, os, re, statistics, sys

args = sys.argv[1:]
max_epoch = None
if args[:1] == ["--epochs"]:
    max_epoch, args = int(args[1]), args[2:]
prefixes = args or [""]
rows = {}
for d in sorted(glob.glob("runs/acc/*/metrics.jsonl")):
    run = os.path.basename(os.path.dirname(d))
    if not any(run.startswith(p) for p in prefixes):
        continue
    m = re.match(r"(.*)-s(\d+)$", run)
    if not m:
        continue
    best, bestp, epochs = None, None, 0
    for line in open(d):
        e = json.loads(line)
        if max_epoch is not None and e["epoch"] > max_epoch:
            break
        epochs = e["epoch"]
        v, p = e.get("val"), e.get("val_point")
        if v and (best is None or v["min_fde"] < best[1]):
            best = (e["epoch"], v["min_fde"], v["min_ade"])
        if p and (bestp is None or p["fde_k1"] < bestp[1]):
            bestp = (e["epoch"], p["fde_k1"], p["ade_k1"])
    rows.setdefault(m.group(1), []).append((int(m.group(2)), epochs, best, bestp))

def ms(xs):
    xs = [x for x in xs if x is not None]
    if not xs:
        return "–"
    sd = statistics.stdev(xs) if len(xs) > 1 else 0.0
    return f"{statistics.mean(xs):.2f} ± {sd:.2f}"

print("| variant | seeds | epochs | val minADE (K=20) | val minFDE (K=20) | val point ADE | val point FDE |")
print("|---|---|---|---|---|---|---|")
for k, rs in rows.items():
    rs.sort()
    print(f"| {k} | {','.join(str(r[0]) for r in rs)} | {rs[0][1]} | "
          f"{ms([r[2][2] for r in rs if r[2]])} | {ms([r[2][1] for r in rs if r[2]])} | "
          f"{ms([r[3][2] for r in rs if r[3]])} | {ms([r[3][1] for r in rs if r[3]])} |")
