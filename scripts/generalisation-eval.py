#!/usr/bin/env python3
"""Evaluate the runs of scripts/generalisation-runs.sh in domain and out of domain
(docs/generalisation.md), every number through gpecnet-core in fixed point.

For every finished run folder under RUNS (default runs/gen):
  1. `gpecnet select` on the run's own validation split (sigma 0.8 / 1.0 / 1.3, N = 0 / 80):
     the lowest validation minFDE wins (ties: minADE). The test sets are not read.
  2. `gpecnet export` with that setting (f32), then `gpecnet quantize --endpoint-only`
     (the MCU form: encoder + decoder + point head, Q15) into OUT/models/.
  3. `gpecnet eval --json --dataset D` of the fixed-point blob on every target D of the run's
     family: a model trained on SDD in metres is scored on sdd-m (in domain) and on the five
     ETH/UCY test scenes (zero-shot); an ETH/UCY leave-one-scene-out model on its own held-out
     scene (in domain) and on sdd-m (zero-shot).
Results go to OUT/results.jsonl, one line per (run, target); a rerun skips what is there.
Then `--summary` prints the markdown tables: mean +- std over the seeds of each variant.

Usage: scripts/generalisation-eval.py [--runs DIR] [--out DIR] [--bin PATH] [--summary]
"""
import argparse, glob, json, os, re, statistics, subprocess, sys

from studylib import mean_std

ETH = ["eth", "hotel", "univ", "zara1", "zara2"]
ap = argparse.ArgumentParser()
ap.add_argument("--runs", default="runs/gen")
ap.add_argument("--out", default="runs/gen-eval")
ap.add_argument("--bin", default="target/release/gpecnet")
ap.add_argument("--summary", action="store_true")
a = ap.parse_args()
os.makedirs(os.path.join(a.out, "models"), exist_ok=True)
results_path = os.path.join(a.out, "results.jsonl")


def run(*args):
    r = subprocess.run([a.bin, *args], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{a.bin} {' '.join(args)} failed:\n{r.stderr}")
    return r.stdout


def load_results():
    out = {}
    if os.path.exists(results_path):
        for line in open(results_path):
            r = json.loads(line)
            out[(r["run"], r["target"])] = r
    return out


def variant_of(run):
    """(variant, seed, targets) of a run folder name."""
    m = re.match(r"(.*)-s(\d+)$", run)
    if not m:
        return None
    v, seed = m.group(1), int(m.group(2))
    if v.startswith("sdd-m"):
        return v, seed, ["sdd-m"] + [f"eth_ucy:{s}" for s in ETH]
    e = re.match(r"eth-(?:syn6-)?(\w+)$", v)
    if e and e.group(1) in ETH:
        return v, seed, [f"eth_ucy:{e.group(1)}", "sdd-m"]
    return None


def evaluate():
    done = load_results()
    runs = sorted(os.path.basename(os.path.dirname(p))
                  for p in glob.glob(os.path.join(a.runs, "*", "checkpoint.bin")))
    for name in runs:
        vs = variant_of(name)
        if vs is None:
            continue
        variant, seed, targets = vs
        rd = os.path.join(a.runs, name)
        cfg = open(os.path.join(rd, "config.toml")).read()
        want = int(re.search(r"num_epochs = (\d+)", cfg).group(1))
        last = sum(1 for _ in open(os.path.join(rd, "metrics.jsonl")))
        if last < want:
            print(f"{name}: {last}/{want} epochs, skipped for now")
            continue
        if all((name, t) in done for t in targets):
            continue
        sel = json.loads(run("select", "--run", rd, "--sigmas", "0.8,1.0,1.3",
                             "--tts", "0,80", "--json"))
        best = min(sel["rows"], key=lambda r: (r["val"]["min_fde"], r["val"]["min_ade"]))
        mdir = os.path.join(a.out, "models")
        f32 = os.path.join(mdir, f"{name}.gpec")
        qe = os.path.join(mdir, f"{name}-qe.gpec")
        flags = ["--sigma", str(best["sigma"])] + (["--tts", str(best["tts"])] if best["tts"] else [])
        if not os.path.exists(f32):
            run("export", "--run", rd, "--name", name, "--out", mdir, *flags)
        if not os.path.exists(qe):
            run("quantize", "--blob", f32, "--out", qe, "--endpoint-only")
        for t in targets:
            if (name, t) in done:
                continue
            r = json.loads(run("eval", "--blob", qe, "--dataset", t, "--json",
                               "--draw", os.path.join(mdir, f"{name}-{t.replace(':', '_')}.svg")))
            row = {"run": name, "variant": variant, "seed": seed, "target": t,
                   "sigma": best["sigma"], "tts": best["tts"],
                   "val_min_fde": best["val"]["min_fde"], "eval": r}
            with open(results_path, "a") as f:
                f.write(json.dumps(row) + "\n")
            done[(name, t)] = row
            e = r
            print(f"{name} on {t}: {e['min_ade']:.3f} / {e['min_fde']:.3f} {e['unit']}, "
                  f"point {e['point_fde']:.3f}, CV {e['cv_fde']:.3f}")


def ms(xs, d=2):
    return mean_std(xs, d)


def summary():
    res = list(load_results().values())
    by = {}
    for r in res:
        by.setdefault((r["variant"], r["target"]), []).append(r)
    targets = ["sdd-m"] + [f"eth_ucy:{s}" for s in ETH]
    variants = sorted({r["variant"] for r in res})

    def kind(variant, target):
        if variant.startswith("sdd-m"):
            return "in domain" if target == "sdd-m" else "zero-shot"
        scene = variant[4:].removeprefix("syn6-")
        return "in domain (leave-one-scene-out)" if target == f"eth_ucy:{scene}" else "zero-shot"

    print("| variant | target | kind | seeds | minADE / minFDE (m, K = 20) | point FDE (m) | CV FDE (m) | min FDE px | point FDE px |")
    print("|---|---|---|---|---|---|---|---|---|")
    for t in targets:
        for v in variants:
            rs = sorted(by.get((v, t), []), key=lambda r: r["seed"])
            if not rs:
                continue
            e = [r["eval"] for r in rs]
            px = [x for x in e if x.get("min_fde_px") is not None]
            print(f"| {v} | {t} | {kind(v, t)} | {','.join(str(r['seed']) for r in rs)} | "
                  f"{ms([x['min_ade'] for x in e], 3)} / {ms([x['min_fde'] for x in e], 3)} | "
                  f"{ms([x['point_fde'] for x in e], 3)} | {e[0]['cv_fde']:.3f} | "
                  + (f"{ms([x['min_fde_px'] for x in px])} | {ms([x['point_fde_px'] for x in px])} |"
                     if px else "– | – |"))
    # ETH/UCY averages per seed, then mean +- std over seeds.
    print()
    print("| variant | ETH/UCY targets | seeds | average minADE / minFDE (m) | average point FDE (m) | average CV FDE (m) |")
    print("|---|---|---|---|---|---|")
    fams = {}
    for r in res:
        if r["target"].startswith("eth_ucy:"):
            if r["variant"].startswith("eth-syn6-"):
                continue
            fam = "eth (in domain, own scene)" if r["variant"].startswith("eth-") else r["variant"]
            fams.setdefault(fam, {}).setdefault(r["seed"], {})[r["target"]] = r["eval"]
    for fam, seeds in sorted(fams.items()):
        full = {s: t for s, t in seeds.items() if len(t) == 5}
        if not full:
            continue
        avg = lambda key: [statistics.mean(t[x][key] for x in t) for t in full.values()]
        cv = statistics.mean(next(iter(full.values()))[x]["cv_fde"] for x in next(iter(full.values())))
        print(f"| {fam} | 5 | {','.join(map(str, sorted(full)))} | {ms(avg('min_ade'), 3)} / "
              f"{ms(avg('min_fde'), 3)} | {ms(avg('point_fde'), 3)} | {cv:.3f} |")


# Published numbers (minADE / minFDE, K = 20; metres, SDD in pixels): PECNet (Mangalam et al.,
# ECCV 2020) and LED (Mao et al., CVPR 2023), both trained in domain.
PUBLISHED = {
    "sdd-m": ("9.96 / 15.88 px", "8.48 / 11.66 px"),
    "eth_ucy:eth": ("0.54 / 0.87", "0.39 / 0.58"),
    "eth_ucy:hotel": ("0.18 / 0.24", "0.11 / 0.17"),
    "eth_ucy:univ": ("0.35 / 0.60", "0.26 / 0.43"),
    "eth_ucy:zara1": ("0.22 / 0.39", "0.18 / 0.26"),
    "eth_ucy:zara2": ("0.17 / 0.30", "0.13 / 0.22"),
    "avg": ("0.29 / 0.48", "0.21 / 0.33"),
}


def per_seed(rows, key):
    """{seed: value} of `key` of the evals in rows, averaged over rows of one seed."""
    by = {}
    for r in rows:
        by.setdefault(r["seed"], []).append(r["eval"][key])
    return {s: statistics.mean(v) for s, v in by.items()}


def pair(rows, px=False):
    if not rows:
        return "not run"
    sfx = "_px" if px else ""
    d = 2 if px else 3
    ade = list(per_seed(rows, "min_ade" + sfx).values())
    fde = list(per_seed(rows, "min_fde" + sfx).values())
    return f"{ms(ade, d)} / {ms(fde, d)} ({len(ade)} seeds)"


def table():
    res = list(load_results().values())
    sel = lambda pred: [r for r in res if pred(r)]
    print("| target | in domain | zero-shot (never trained on it) | zero-shot + 6 % synthetic | "
          "constant velocity FDE | zero-shot point FDE | PECNet (published, in domain) | LED (published, in domain) |")
    print("|---|---|---|---|---|---|---|---|")
    for sc in ["sdd-m"] + [f"eth_ucy:{s}" for s in ETH]:
        if sc == "sdd-m":
            ind = sel(lambda r: r["variant"] == "sdd-m" and r["target"] == sc)
            zs = sel(lambda r: r["variant"].startswith("eth-") and r["variant"][4:] in ETH
                     and r["target"] == sc)
            syn = sel(lambda r: r["variant"] == "eth-syn6-eth" and r["target"] == sc)
            base = sel(lambda r: r["variant"] == "eth-eth" and r["target"] == sc)
            cells = [f"{pair(ind)}; px: {pair(ind, True)}",
                     f"{pair(zs)} (the 5 ETH/UCY split models); px: {pair(zs, True)}",
                     f"{pair(syn)} vs {pair(base)} without (ETH split model)"]
            label = "SDD test (m; px per scene)"
        else:
            ind = sel(lambda r: r["variant"] == f"eth-{sc[8:]}" and r["target"] == sc)
            zs = sel(lambda r: r["variant"] == "sdd-m" and r["target"] == sc)
            syn = sel(lambda r: r["variant"] == "sdd-m-syn6" and r["target"] == sc)
            cells = [pair(ind), pair(zs), pair(syn)]
            label = sc.split(":")[1].upper()
        cv = (ind or zs)[0]["eval"]["cv_fde"] if (ind or zs) else float("nan")
        pt = list(per_seed(zs, "point_fde").values()) if zs else []
        pub = PUBLISHED[sc]
        print(f"| {label} | " + " | ".join(cells) + f" | {cv:.3f} | {ms(pt, 3) if pt else '–'} | "
              f"{pub[0]} | {pub[1]} |")
    # ETH/UCY average over the five targets, per seed.
    def avg(variant_of_target):
        seeds = {}
        for sc in ETH:
            for r in sel(lambda r: r["variant"] == variant_of_target(sc) and r["target"] == f"eth_ucy:{sc}"):
                seeds.setdefault(r["seed"], {})[sc] = r["eval"]
        full = [t for t in seeds.values() if len(t) == 5]
        if not full:
            return "not run"
        a = [statistics.mean(t[x]["min_ade"] for x in t) for t in full]
        f = [statistics.mean(t[x]["min_fde"] for x in t) for t in full]
        return f"{ms(a, 3)} / {ms(f, 3)} ({len(full)} seeds)"
    cvs = [r["eval"]["cv_fde"] for r in sel(lambda r: r["variant"] == "sdd-m" and r["seed"] == 1
                                            and r["target"].startswith("eth_ucy:"))]
    pts = {}
    for r in sel(lambda r: r["variant"] == "sdd-m" and r["target"].startswith("eth_ucy:")):
        pts.setdefault(r["seed"], []).append(r["eval"]["point_fde"])
    pt = [statistics.mean(v) for v in pts.values() if len(v) == 5]
    print(f"| **ETH/UCY average** | {avg(lambda sc: f'eth-{sc}')} | {avg(lambda sc: 'sdd-m')} | "
          f"{avg(lambda sc: 'sdd-m-syn6')} | {statistics.mean(cvs) if cvs else float('nan'):.3f} | "
          f"{ms(pt, 3) if pt else '–'} | {PUBLISHED['avg'][0]} | {PUBLISHED['avg'][1]} |")


if a.summary:
    summary()
    print()
    table()
else:
    evaluate()
