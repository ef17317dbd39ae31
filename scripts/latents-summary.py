#!/usr/bin/env python3
"""Each variant of scripts/latents-runs.sh: its seeds' best validation epoch, then mean ± std
(sample std, n - 1) over the seeds of the validation numbers in proposal.json (metres, K = 20):
minFDE of the training loop, and through gpecnet-core minADE, KDE NLL, hits within 0.5 / 1 m,
and the starters' minFDE (standing when forecast, > 1 m away at the horizon).

Usage: scripts/latents-summary.py [OUT]   (default runs/latents)
"""
import glob, json, os, re, sys

from studylib import mean_std as ms

out = sys.argv[1] if len(sys.argv) > 1 else "runs/latents"


variants = {}
for p in sorted(glob.glob(os.path.join(out, "*-s*", "proposal.json"))):
    name, seed = re.match(r"(.*)-s(\d+)$", os.path.basename(os.path.dirname(p))).groups()
    variants.setdefault(name, {})[int(seed)] = json.load(open(p))

print("| variant | seeds | best epochs | val minFDE, per seed | mean ± std | minADE | KDE NLL "
      "| within 0.5 / 1 m | starters (n) minFDE |")
print("|---|---|---|---|---|---|---|---|---|")
for name, runs in variants.items():
    seeds = sorted(runs)
    fde = [runs[s]["val"]["val_min_fde"] for s in seeds]
    core = [runs[s].get("val_core") or {} for s in seeds]
    ade = [c["min_ade"] for c in core if c]
    nll = [c["kde_nll"] for c in core if c]
    h0 = [c["hits"][0] * 100 for c in core if c]
    h1 = [c["hits"][1] * 100 for c in core if c]
    st = [c["starters"] for c in core if c.get("starters")]
    st_txt = f"({st[0]['n']}) {ms([x['min_fde'] for x in st], 3)}" if st else "-"
    print(f"| {name} | {','.join(map(str, seeds))} | {', '.join(str(runs[s]['epoch']) for s in seeds)} "
          f"| {' / '.join(f'{x:.4f}' for x in fde)} | {ms(fde, 4)} | {ms(ade, 3)} | {ms(nll, 3)} "
          f"| {ms(h0, 1)} % / {ms(h1, 1)} % | {st_txt} |")
