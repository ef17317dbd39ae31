#!/usr/bin/env python3
"""The starters study of docs/generalisation.md ("Starters in the union"): for each variant
of scripts/universal-runs.sh held out on one scene, mean ± std over its seeds of

* validation (the combined split that selected the epoch): minFDE, and the starters' minFDE
  (`proposal.json`: `val.val_min_fde`, `val_core.starters`);
* the held-out scene's test set: minFDE overall, of the starters, the stoppers and the rest
  (`gpecnet eval --json`: `changes`);
* SDD's test set (metres): minFDE overall, of the starters and of the rest;

and the shipped default's numbers on the same test sets (the variant folder's baseline/).

Usage: scripts/starters-summary.py SCENE RUNS:PREFIX [RUNS:PREFIX ...]
       (say: univ runs/universal-joint:jb runs/universal-joint-st10:jbst10)
"""
import json
import os
import statistics
import sys


def groups(report):
    return {c["scene"]: c for c in report["changes"]}


def run_numbers(runs, prefix, scene, seed):
    name = f"{runs}/{prefix}-{scene}-s{seed}"
    # MODE=cvae keeps the proposal beside the CVAE's run, the other modes in the run itself.
    proposal = next(
        (p for p in (f"{name}/proposal.json", f"{name}-h8/proposal.json") if os.path.exists(p)),
        f"{name}/proposal.json",
    )
    paths = [f"{name}-eth_ucy_{scene}.json", f"{name}-sdd-m.json", proposal]
    if not all(os.path.exists(p) for p in paths):
        return None
    target, sdd, proposal = (json.load(open(p)) for p in paths)
    t, s = groups(target), groups(sdd)
    starters = proposal["val_core"].get("starters") or {}
    return {
        "val": proposal["val"]["val_min_fde"],
        "val_st": starters.get("min_fde", float("nan")),
        "t": target["min_fde"],
        "t_st": t["starters"]["min_fde"],
        "t_sp": t["stoppers"]["min_fde"],
        "t_ne": t["neither"]["min_fde"],
        "sdd": sdd["min_fde"],
        "sdd_px": sdd["min_fde_px"],
        "sdd_st": s["starters"]["min_fde"],
        "sdd_ne": s["neither"]["min_fde"],
        "n": (t["starters"]["n"], s["starters"]["n"], starters.get("n", 0)),
    }


def mean_std(xs, digits=3):
    xs = [x for x in xs if x == x]  # proposals older than the starters' record give NaN
    if len(xs) < 2:
        return f"{xs[0]:.{digits}f}" if xs else "–"
    return f"{statistics.mean(xs):.{digits}f} ± {statistics.stdev(xs):.{digits}f}"


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    scene, variants = sys.argv[1], sys.argv[2:]
    print(
        f"| variant | seeds | validation minFDE | validation starters | {scene.upper()} minFDE | "
        f"{scene.upper()} starters | {scene.upper()} stoppers | {scene.upper()} other | "
        "SDD minFDE (m; px) | SDD starters | SDD other |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    baselines = []
    for v in variants:
        runs, prefix = v.split(":")
        rows = [r for r in (run_numbers(runs, prefix, scene, s) for s in (1, 2, 3)) if r]
        if not rows:
            continue
        col = lambda k, digits=3: mean_std([r[k] for r in rows], digits)
        print(
            f"| `{prefix}` | {len(rows)} | {col('val')} | {col('val_st')} | {col('t')} | "
            f"{col('t_st')} | {col('t_sp')} | {col('t_ne')} | {col('sdd')}; {col('sdd_px', 2)} | "
            f"{col('sdd_st')} | {col('sdd_ne')} |"
        )
        baselines.append((f"{runs}/baseline/sdd-m-lp-qe", rows[0]["n"]))
    # The first variant folder whose baseline reports were made with the motion groups.
    for b, n in baselines:
        target = json.load(open(f"{b}-eth_ucy_{scene}.json"))
        sdd = json.load(open(f"{b}-sdd-m.json"))
        if "changes" not in target or "changes" not in sdd:
            continue
        t, s = groups(target), groups(sdd)
        print(
            f"| `sdd-m-lp-qe` (shipped) | – | – | – | {target['min_fde']:.3f} | "
            f"{t['starters']['min_fde']:.3f} | {t['stoppers']['min_fde']:.3f} | "
            f"{t['neither']['min_fde']:.3f} | {sdd['min_fde']:.3f}; {sdd['min_fde_px']:.2f} | "
            f"{s['starters']['min_fde']:.3f} | {s['neither']['min_fde']:.3f} |"
        )
        print(
            f"\nStarters: {n[0]} in {scene.upper()}'s test set, {n[1]} in SDD's, {n[2]} in the "
            "validation split. Validation minFDE is each mode's own selection score: the "
            "combined split's plain mean (MODE=cvae) or its parts' mean (the balanced modes)."
        )
        break


if __name__ == "__main__":
    main()
