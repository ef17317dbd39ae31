#!/usr/bin/env python3
"""Markdown tables of docs/online.md from `gpecnet stream --json` outputs.

    python3 scripts/online-summary.py OUT_DIR   # reads OUT_DIR/<set>-p<P>.json (scripts/online-runs.sh)
"""
import json
import os
import sys

SETS = ["sdd-m", "eth_ucy-eth", "eth_ucy-hotel", "eth_ucy-univ", "eth_ucy-zara1", "eth_ucy-zara2"]
MIN_N = 300


def best(f):
    return min([x for x in [f["head"]] + f["cv"] if x is not None])


def row(r, label):
    f = r["fde"]
    st = r["by_motion"]["standing"]
    ph = [c["r90"] for c in r["per_horizon"]]
    head = "–" if f["head"] is None else f"{f['head']:.3f}"
    return (f"| {label} | {'on' if r['adapt'] else 'off'} | {r['scored']} | {r['endpoint']['r50']:.3f} | "
            f"{r['endpoint']['r90']:.3f} | {min(ph):.3f}–{max(ph):.3f} | {st['r90']:.3f} ({st['n']}) | "
            f"{r['starters']['r90']:.3f} ({r['starters']['n']}) | {r['mean_r90']:.3f} / {r['oracle_r90']:.3f} | "
            f"{head} | {f['cv'][0]:.3f} | {f['cv'][1]:.3f} | {f['cv'][2]:.3f} | {f['point']:.3f} "
            f"({f['point'] / best(f):.3f}) |")


def main():
    d = sys.argv[1]
    for p in (12, 2):
        print(f"\n### P = {p}\n")
        print("| scene (recordings pooled) | loop | scored | r50 | r90 | r90 per horizon | r90 standing (n) "
              "| r90 starters (n) | mean r90 / oracle (m) | FDE head | CV1 | CV2 | CV4 | point (÷ best) |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for s in SETS:
            path = os.path.join(d, f"{s}-p{p}.json")
            if not os.path.exists(path):
                continue
            j = json.load(open(path))
            for r in j["pooled"]:
                print(row(r, s))
            if len(j["recordings"]) > 1:
                for pair in j["recordings"]:
                    if pair[1]["scored"] >= MIN_N:
                        for r in pair:
                            print(row(r, f"&nbsp;&nbsp;{s}/{r['scene']}"))


if __name__ == "__main__":
    main()
