#!/usr/bin/env python3
"""Tabulates scripts/flight-runs.sh's JSON (docs/camera.md, "Synthetic flight").

Usage: scripts/flight-summary.py [DIR]   (default target/flight)
Per scene, the model's rows (loop off): best-of-20 minFDE and the point forecast's FDE clean
and through the simulated drone under each condition, with the change against clean, and
the drone's ground-point error overall and while yawing.
"""
import os
import sys

from studylib import load_json

d = sys.argv[1] if len(sys.argv) > 1 else "target/flight"
scenes = ["eth", "hotel", "univ", "zara1", "zara2", "sdd-m"]
conds = [
    ("flight", "2 px, 0.5° i.i.d., no filter"),
    ("flight-filter", "2 px, 0.5° i.i.d. + filter"),
    ("flight-drift5-filter", "2 px, 0.5° drifting (τ 5 s) + filter"),
    ("flight-att01-filter", "2 px, 0.1° i.i.d. + filter"),
    ("flight-px-filter", "2 px, no attitude error + filter"),
]


def load(name):
    return load_json(os.path.join(d, name + ".json"))


def off(js):
    return js["pooled"][0]


print("| scene | clean minFDE / point FDE (m) | " + " | ".join(c[1] for c in conds) + " |")
print("|---|---|" + "---|" * len(conds))
for sc in scenes:
    clean = load(f"{sc}-clean")
    if clean is None:
        continue
    c = off(clean)["fde"]
    row = [sc, f"{c['min_k']:.3f} / {c['point']:.3f}"]
    for name, _ in conds:
        js = load(f"{sc}-{name}")
        if js is None:
            row.append("–")
            continue
        f = off(js)["fde"]
        row.append(
            f"{f['min_k']:.3f} ({100 * (f['min_k'] / c['min_k'] - 1):+.0f} %) / "
            f"{f['point']:.3f} ({100 * (f['point'] / c['point'] - 1):+.0f} %)"
        )
    print("| " + " | ".join(row) + " |")

print()
print("| scene | condition | detected / positions | ground error RMS (m) | while yawing (n) | max (m) | max while yawing (m) | model σ RMS vs realised per axis (m) |")
print("|---|---|---|---|---|---|---|---|")
for sc in scenes:
    for name, label in conds:
        js = load(f"{sc}-{name}")
        if js is None or off(js).get("flight") is None:
            continue
        s = off(js)["flight"]
        print(
            f"| {sc} | {label} | {s['detections']} / {s['positions']} | {s['rms_error_m']:.3f} | "
            f"{s['rms_error_yawing_m']:.3f} ({s['detections_yawing']}) | {s['max_error_m']:.2f} | "
            f"{s['max_error_yawing_m']:.2f} | {s['rms_model_sigma_m']:.3f} vs {s['rms_error_m'] / 2 ** 0.5:.3f} |"
        )
