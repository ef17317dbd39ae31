#!/usr/bin/env python3
"""Tables of docs/camera.md's "Noise-aware training" from scripts/noise-runs.sh's JSON files.

Usage: scripts/noise-summary.py [RUNS] [--split test|val]   (RUNS default target/noise/runs)

Per group (base = the shipped weights/sdd-m-lp-qe.gpec; clean, n005, n010 = the recipe with
sigma_train 0, 0.05, 0.1 m, seeds 1-3): mean ± sample standard deviation over the seeds found.
Streams: `pooled[0]` (loop off) of `gpecnet stream --json`: best-of-20 `fde.min_k`, the point
`fde.point`. Conditions: clean, noise (0.1 m, filter off), filter (0.1 m, --filter
--filter-sigma 0.1). Percentages are against the same model's clean figure, seed by seed, then
averaged; "vs shipped" against the shipped model's clean figure.
"""

import json
import statistics
import sys
from pathlib import Path

SCENES = ["hotel", "zara1", "zara2", "eth", "univ"]
GROUPS = [
    ("base", "shipped `sdd-m-lp-qe`"),
    ("clean", "recipe, σ_train = 0"),
    ("n005", "recipe, σ_train = 0.05 m"),
    ("n010", "recipe, σ_train = 0.1 m"),
]
CONDS = ["clean", "noise", "filter"]


def load(path):
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def runs_of(root, group):
    """Run names of a group with at least one JSON file."""
    if group == "base":
        names = ["base"]
    else:
        names = [f"{group}-s{s}" for s in range(1, 10)]
    return [n for n in names if any((root / "json").glob(f"{n}-*.json"))]


def stream(root, name, scene, split, cond):
    d = load(root / "json" / f"{name}-{scene}-{split}-{cond}.json")
    if d is None:
        return None
    fde = d["pooled"][0]["fde"]
    return fde["min_k"], fde["point"]


def fmt(xs, digits=3):
    xs = [x for x in xs if x is not None]
    if not xs:
        return "–"
    m = statistics.fmean(xs)
    if len(xs) == 1:
        return f"{m:.{digits}f}"
    return f"{m:.{digits}f} ± {statistics.stdev(xs):.{digits}f}"


def pct(xs):
    xs = [x for x in xs if x is not None]
    if not xs:
        return "–"
    m = statistics.fmean(xs)
    if len(xs) == 1:
        return f"{100 * m:+.0f} %"
    return f"{100 * m:+.0f} ± {100 * statistics.stdev(xs):.0f} %"


def stream_table(root, split, which):
    """which: 0 = best-of-20, 1 = point."""
    label = "best-of-20 minFDE" if which == 0 else "point FDE (loop off)"
    out = [
        f"{label}, m, {split} split; in brackets: against the same model's clean figure\n",
        "| scene | model | n | clean | σ = 0.1 m, filter off | σ = 0.1 m, filter on |",
        "|---|---|---|---|---|---|",
    ]
    worst = {}
    worst_ship = {}
    for scene in SCENES:
        ship = stream(root, "base", scene, split, "clean")
        for g, words in GROUPS:
            names = runs_of(root, g)
            cols = {c: [] for c in CONDS}
            rel = {c: [] for c in CONDS}
            for n in names:
                v = {c: stream(root, n, scene, split, c) for c in CONDS}
                if v["clean"] is None:
                    continue
                for c in CONDS:
                    if v[c] is None:
                        continue
                    cols[c].append(v[c][which])
                    rel[c].append(v[c][which] / v["clean"][which] - 1)
            if not cols["clean"]:
                continue
            for c in ("noise", "filter"):
                if rel[c]:
                    key = (g, c)
                    worst[key] = max(worst.get(key, -9), statistics.fmean(rel[c]))
                if cols[c] and ship is not None:
                    r = statistics.fmean(cols[c]) / ship[which] - 1
                    worst_ship[(g, c)] = max(worst_ship.get((g, c), -9), r)
                    worst_ship[(g, "clean")] = max(
                        worst_ship.get((g, "clean"), -9),
                        statistics.fmean(cols["clean"]) / ship[which] - 1,
                    )
            out.append(
                f"| {scene.upper()} | {words} | {len(cols['clean'])} | {fmt(cols['clean'])} | "
                f"{fmt(cols['noise'])} ({pct(rel['noise'])}) | {fmt(cols['filter'])} ({pct(rel['filter'])}) |"
            )
    out.append("")
    out.append(f"Worst scene ({label}, {split}), mean over seeds of (σ = 0.1 m / clean − 1):\n")
    out.append("| model | filter off | filter on |")
    out.append("|---|---|---|")
    for g, words in GROUPS:
        if (g, "noise") in worst:
            out.append(
                f"| {words} | {100 * worst[(g, 'noise')]:+.1f} % | {100 * worst.get((g, 'filter'), float('nan')):+.1f} % |"
            )
    out.append("")
    out.append(
        f"Worst scene ({label}, {split}) against the shipped model's clean figure, "
        "(mean over seeds) / (shipped, clean) − 1:\n"
    )
    out.append("| model | clean | σ = 0.1 m, filter off | σ = 0.1 m, filter on |")
    out.append("|---|---|---|---|")
    for g, words in GROUPS:
        if (g, "noise") in worst_ship:
            cells = [f"{100 * worst_ship.get((g, c), float('nan')):+.1f} %" for c in CONDS]
            out.append(f"| {words} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def val_means(root):
    """Mean over the five scenes' validation recordings (the σ_train choice)."""
    out = [
        "Validation split, mean over the five scenes (m; mean ± std over seeds):\n",
        "| model | minFDE clean | minFDE σ = 0.1 m off | minFDE σ = 0.1 m filter | point clean | point σ = 0.1 m off | point σ = 0.1 m filter |",
        "|---|---|---|---|---|---|---|",
    ]
    for g, words in GROUPS:
        per = {(c, w): [] for c in CONDS for w in (0, 1)}
        for n in runs_of(root, g):
            vals = {c: [stream(root, n, sc, "val", c) for sc in SCENES] for c in CONDS}
            for c in CONDS:
                if all(v is not None for v in vals[c]):
                    for w in (0, 1):
                        per[(c, w)].append(statistics.fmean(v[w] for v in vals[c]))
        if not per[("clean", 0)]:
            continue
        cells = [fmt(per[(c, w)]) for w in (0, 1) for c in CONDS]
        out.append(f"| {words} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def clean_accuracy(root):
    out = [
        "Clean accuracy, test windows (`gpecnet eval`; mean ± std over seeds):\n",
        "| model | SDD minFDE px | SDD minADE / minFDE m | SDD point FDE m | ETH/UCY minADE / minFDE m (mean of 5 scenes) | ETH/UCY point FDE m |",
        "|---|---|---|---|---|---|",
    ]
    for g, words in GROUPS:
        px, ade, fde, pt, eade, efde, ept = ([] for _ in range(7))
        for n in runs_of(root, g):
            d = load(root / "json" / f"{n}-sdd-m.json")
            if d is not None:
                px.append(d["min_fde_px"])
                ade.append(d["min_ade"])
                fde.append(d["min_fde"])
                pt.append(d["point_fde"])
            es = [load(root / "json" / f"{n}-{sc}-eval.json") for sc in SCENES]
            if all(e is not None for e in es):
                eade.append(statistics.fmean(e["min_ade"] for e in es))
                efde.append(statistics.fmean(e["min_fde"] for e in es))
                ept.append(statistics.fmean(e["point_fde"] for e in es))
        if not px:
            continue
        out.append(
            f"| {words} | {fmt(px, 2)} | {fmt(ade)} / {fmt(fde)} | {fmt(pt)} | {fmt(eade)} / {fmt(efde)} | {fmt(ept)} |"
        )
    return "\n".join(out) + "\n"


def main():
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="?", default="target/noise/runs")
    ap.add_argument("--split", choices=["test", "val"], default="test")
    a = ap.parse_args()
    root = Path(a.runs)
    if a.split == "val":
        print(val_means(root))
    print(stream_table(root, a.split, 0))
    print(stream_table(root, a.split, 1))
    if a.split == "test":
        print(clean_accuracy(root))


if __name__ == "__main__":
    main()
