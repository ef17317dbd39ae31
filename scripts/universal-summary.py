#!/usr/bin/env python3
"""The tables of docs/generalisation.md, "One model for every scene", from the eval JSONs that
scripts/universal-runs.sh writes (every number through gpecnet-core, fixed point, K = 20).

Usage: scripts/universal-summary.py [RUNS [PREFIX]]   (default runs/universal uni;
       runs/universal-joint jb for MODE=joint)
"""
import glob, json, os, re, statistics, sys

from studylib import load_json as load, mean_std

runs = sys.argv[1] if len(sys.argv) > 1 else "runs/universal"
prefix = sys.argv[2] if len(sys.argv) > 2 else "uni"
ETH = ["eth", "hotel", "univ", "zara1", "zara2"]


def ms(xs, d=3):
    return mean_std(xs, d)


def seeds_of(sc):
    out = {}
    for p in glob.glob(os.path.join(runs, f"{prefix}-{sc}-s*-eth_ucy_{sc}.json")):
        s = int(re.search(r"-s(\d+)-eth_ucy", p).group(1))
        sdd = load(os.path.join(runs, f"{prefix}-{sc}-s{s}-sdd-m.json"))
        if sdd is None:
            continue
        rd = os.path.join(runs, f"{prefix}-{sc}-s{s}")
        jsonl = os.path.join(rd, "metrics.jsonl")
        if os.path.exists(jsonl):  # MODE=cvae: the CVAE's training run, then its proposal
            lines = [json.loads(l) for l in open(jsonl)]
            best = min(lines, key=lambda r: r["val"]["min_fde"])
            prop = load(rd + "-h8/proposal.json")
            cvae = {"best_epoch": best["epoch"], "epochs": len(lines), "val_fde": best["val"]["min_fde"]}
        else:  # MODE=joint: the proposal run alone (the CVAE is the shipped one)
            prop = load(os.path.join(rd, "proposal.json"))
            cvae = {}
        out[s] = {"t": load(p), "sdd": sdd, **cvae,
                  "prop_val": prop["val"]["val_min_fde"] if prop else None,
                  "prop_epoch": prop["epoch"] if prop else None}
    return dict(sorted(out.items()))

print("| target | seeds | universal on target: minADE / minFDE (m) | universal on SDD test (m; px) "
      "| sdd-m-lp-qe on target (zero-shot) | universal point FDE | CV FDE | best epoch (val) / proposal val minFDE |")
print("|---|---|---|---|---|---|---|---|")
base_sdd = load(os.path.join(runs, "baseline", "sdd-m-lp-qe-sdd-m.json"))
done = {}
for sc in ETH:
    r = seeds_of(sc)
    if not r:
        continue
    done[sc] = r
    b = load(os.path.join(runs, "baseline", f"sdd-m-lp-qe-eth_ucy_{sc}.json"))
    t = [x["t"] for x in r.values()]
    s = [x["sdd"] for x in r.values()]
    print(f"| {sc.upper()} | {','.join(map(str, r))} | {ms([x['min_ade'] for x in t])} / "
          f"{ms([x['min_fde'] for x in t])} | {ms([x['min_ade'] for x in s])} / "
          f"{ms([x['min_fde'] for x in s])}; {ms([x['min_ade_px'] for x in s], 2)} / "
          f"{ms([x['min_fde_px'] for x in s], 2)} px | {b['min_ade']:.3f} / {b['min_fde']:.3f} | "
          f"{ms([x['point_fde'] for x in t])} (zero-shot: {b['point_fde']:.3f}) | {t[0]['cv_fde']:.3f} | "
          + ", ".join((f"{x['best_epoch']}/{x['epochs']} {x['val_fde']:.3f} m / " if "val_fde" in x else "")
                      + f"{x['prop_val']:.3f} m (epoch {x['prop_epoch']})" for x in r.values()) + " |")
print(f"| SDD, shipped `sdd-m-lp-qe` (in domain) | – | – | {base_sdd['min_ade']:.3f} / "
      f"{base_sdd['min_fde']:.3f}; {base_sdd['min_ade_px']:.2f} / {base_sdd['min_fde_px']:.2f} px | – | – | "
      f"{base_sdd['cv_fde']:.3f} | – |")

# Leave-one-out average over the scenes finished with all seeds: per seed, then mean ± std.
full = [sc for sc in done if len(done[sc]) >= 3]
if full:
    seeds = sorted(set.intersection(*(set(done[sc]) for sc in full)))
    avg = lambda k: [statistics.mean(done[sc][s]["t"][k] for sc in full) for s in seeds]
    bl = [load(os.path.join(runs, "baseline", f"sdd-m-lp-qe-eth_ucy_{sc}.json")) for sc in full]
    print()
    print(f"Average over {', '.join(x.upper() for x in full)} (seeds {seeds}): universal "
          f"{ms(avg('min_ade'))} / {ms(avg('min_fde'))} m; sdd-m-lp-qe "
          f"{statistics.mean(x['min_ade'] for x in bl):.3f} / {statistics.mean(x['min_fde'] for x in bl):.3f} m; "
          f"point FDE {ms(avg('point_fde'))} vs CV {statistics.mean(x['cv_fde'] for x in bl):.3f} m")
    sdd_avg = lambda k: [statistics.mean(done[sc][s]["sdd"][k] for sc in full) for s in seeds]
    print(f"SDD test through the five split models (per seed, the mean of the splits): "
          f"{ms(sdd_avg('min_ade_px'), 2)} / {ms(sdd_avg('min_fde_px'), 2)} px; sdd-m-lp-qe "
          f"{base_sdd['min_ade_px']:.2f} / {base_sdd['min_fde_px']:.2f} px")

# As deployed: the held-out scene's test recordings streamed through the track table and the
# online loop (`gpecnet stream`), endpoint r50 / r90 coverage (goal 50 / 90 %) and mean r90,
# loop off (the radii fitted on validation) and on (calibrated from the truth 4.8 s later).
def stream(p):
    d = load(p)
    if d is None:
        return None
    return {x["adapt"]: x for x in d["pooled"]}


def cov(rows, on):
    r50 = [100 * r[on]["endpoint"]["r50"] for r in rows]
    r90 = [100 * r[on]["endpoint"]["r90"] for r in rows]
    mr = [r[on]["mean_r90"] for r in rows]
    st = [100 * r[on]["starters"]["r90"] for r in rows]
    return f"{ms(r50, 1)} / {ms(r90, 1)} %, {ms(mr, 2)} m; starters {ms(st, 1)} %"


print()
print("| target | model | recordings' forecasts scored | loop off: r50 / r90 coverage, mean r90; starters' r90 "
      "| loop on: the same |")
print("|---|---|---|---|---|")
for sc in ETH:
    base = stream(os.path.join(runs, "baseline", f"sdd-m-lp-qe-stream-{sc}.json"))
    ours = [stream(os.path.join(runs, f"{prefix}-{sc}-s{s}-stream-{sc}.json")) for s in (1, 2, 3)]
    ours = [x for x in ours if x]
    if base:
        print(f"| {sc.upper()} | sdd-m-lp-qe | {base[False]['endpoint']['n']} | {cov([base], False)} | {cov([base], True)} |")
    if ours:
        print(f"| {sc.upper()} | {prefix} ({len(ours)} seeds) | {ours[0][False]['endpoint']['n']} | "
              f"{cov(ours, False)} | {cov(ours, True)} |")

# The point forecast (the point head, static: no online loop) against constant velocity with
# its window chosen on validation, on every held-out scene and on SDD's test set (px, scene
# by scene); the point head's own validation epoch when it was trained beside the proposal.
print()
print("| test set | point FDE of these models (seeds) | `sdd-m-lp-qe`'s point FDE | constant velocity FDE "
      "| seeds better than constant velocity | point head: epoch, validation FDE (balanced) |")
print("|---|---|---|---|---|---|")
for sc in ETH + ["sdd"]:
    rows = done.get(sc) if sc != "sdd" else None
    if sc == "sdd":
        t = [x["sdd"] for r in done.values() for x in r.values()]
        key, cvk, unit, b = "point_fde_px", "cv_fde_px", " px", base_sdd
    else:
        if not rows:
            continue
        t = [x["t"] for x in rows.values()]
        key, cvk, unit = "point_fde", "cv_fde", " m"
        b = load(os.path.join(runs, "baseline", f"sdd-m-lp-qe-eth_ucy_{sc}.json"))
    if not t or b is None:
        continue
    d = 2 if unit == " px" else 3
    cv = t[0][cvk]
    wins = sum(x[key] < x[cvk] for x in t)
    heads = "–"
    if rows:
        props = [load(os.path.join(runs, f"{prefix}-{sc}-s{s}", "proposal.json")) for s in rows]
        hs = [p["point_head"] for p in props if p and p.get("point_head")]
        if hs:
            heads = ", ".join(f"{h['epoch']}: {h['val_fde']:.3f}" for h in hs)
    label = "SDD (every split's models)" if sc == "sdd" else sc.upper()
    print(f"| {label} | {ms([x[key] for x in t], d)}{unit} | {b[key]:.{d}f}{unit} | {cv:.{d}f}{unit} "
          f"| {wins} of {len(t)} | {heads} |")

# Starters (standing when forecast, more than 1 m away at the horizon) and everyone else, on
# every held-out scene and on SDD's test set: best-of-20 minFDE of these models against the
# shipped default's (`gpecnet eval --json`, `changes`).
def group(d, name):
    return next((g for g in d.get("changes") or [] if g["scene"] == name), None)


print()
print("| test set | starters (n) minFDE: these models | `sdd-m-lp-qe` | ratio | other windows (n) minFDE: these models | `sdd-m-lp-qe` |")
print("|---|---|---|---|---|---|")
for sc in ETH + ["sdd"]:
    if sc == "sdd":
        t = [x["sdd"] for r in done.values() for x in r.values()]
        b = base_sdd
    else:
        if sc not in done:
            continue
        t = [x["t"] for x in done[sc].values()]
        b = load(os.path.join(runs, "baseline", f"sdd-m-lp-qe-eth_ucy_{sc}.json"))
    bs, bo = (group(b, "starters"), group(b, "neither")) if b else (None, None)
    st = [group(x, "starters") for x in t]
    ot = [group(x, "neither") for x in t]
    if not bs or not all(st) or not all(ot):
        continue
    mean = statistics.mean(g["min_fde"] for g in st)
    label = "SDD (every split's models)" if sc == "sdd" else sc.upper()
    print(f"| {label} | ({bs['n']}) {ms([g['min_fde'] for g in st])} | {bs['min_fde']:.3f} | {mean / bs['min_fde']:.2f} "
          f"| ({bo['n']}) {ms([g['min_fde'] for g in ot])} | {bo['min_fde']:.3f} |")
