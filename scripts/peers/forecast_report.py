#!/usr/bin/env python3
"""The table of scripts/peers/forecast-bench.sh: medians over rounds of each process's median
per call, ratios onnxruntime time / gpecnet time (> 1: gpecnet faster), the agreement of
onnxruntime with the core; written between <!-- forecast:begin --> and <!-- forecast:end -->
of --doc (appended when missing) and --readme (inserted before <!-- peers:begin --> when
missing).
"""

import argparse
import datetime
import json
import platform
import statistics
import subprocess
import sys

CASES = [("ped", "one pedestrian"), ("crowd16", "16 pedestrians (one drone frame)"),
         ("set", "whole sdd-m test split (2,829 windows)")]
BEGIN, END = "<!-- forecast:begin -->", "<!-- forecast:end -->"


def fmt_s(s):
    if s >= 1:
        return f"{s:.2f} s"
    if s >= 1e-3:
        return f"{s * 1e3:.2f} ms"
    return f"{s * 1e6:.1f} µs"


def cpu():
    name, flags = platform.processor() or "unknown CPU", set()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name") and name in ("unknown CPU", "x86_64", ""):
                    name = line.split(":", 1)[1].strip()
                if line.startswith("flags"):
                    flags = set(line.split(":", 1)[1].split())
    except OSError:
        pass
    vec = [v for v in ("avx2", "fma", "avx512f") if v in flags]
    return f"{name} ({', '.join(vec) or 'no AVX2'})"


def replace(text, block, before=None):
    if BEGIN in text and END in text:
        a, b = text.index(BEGIN), text.index(END) + len(END)
        return text[:a] + block + text[b:]
    if before and before in text:
        i = text.index(before)
        return text[:i] + block + "\n\n" + text[i:]
    return text.rstrip("\n") + "\n\n" + block + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--results", required=True)
    ap.add_argument("--rounds", type=int, required=True)
    ap.add_argument("--command", required=True)
    ap.add_argument("--doc")
    ap.add_argument("--readme")
    a = ap.parse_args()
    times, agree, loads, versions = {}, {}, [], set()
    with open(a.results) as f:
        for line in f:
            r = json.loads(line)
            if "loadavg" in r:
                loads.append(r["loadavg"])
                continue
            key = (r["model"], r["impl"])
            for case, s in r["seconds_per_call"].items():
                times.setdefault(key, {}).setdefault(case, []).append(s)
            if r["impl"] == "ort":
                versions.add(r["version"])
                agree.setdefault(r["model"], []).append((r["max_abs_diff"], r["ok"], r["tol"]))
    med = {k: {c: statistics.median(v) for c, v in cs.items()} for k, cs in times.items()}
    models = sorted({m for m, _ in med})
    try:
        commit = subprocess.run(["git", "log", "-1", "--format=%h"], capture_output=True,
                                text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit = "?"
    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d")
    lines = [BEGIN, f"The shipped defaults' whole forecast (K = 20 endpoints, probabilities, point forecast, radii) next to onnxruntime, one thread each. `{a.command}` ({a.rounds} interleaved rounds, medians), commit `{commit}`, {date}; {cpu()}, {', '.join(sorted(versions))}; 1-minute load {min(loads, default=0):.1f}–{max(loads, default=0):.1f}. gpecnet: the scalar `Predictor::predict_forecast` one window at a time, and the batched `HostBatchPredictor::predict_forecasts` (8 lanes, the same bits, checked on every window before timing); onnxruntime: the forecast subgraph of `gpecnet onnx` (x → d, point, prob, radii), all windows of a case in one call. **Ratio = onnxruntime time / gpecnet time (> 1: gpecnet faster).**", "",
             "| model | case | gpecnet scalar | gpecnet batched | onnxruntime | ratio: batched (scalar) |",
             "|---|---|---|---|---|---|"]
    for m in models:
        g, b, o = med.get((m, "gpecnet"), {}), med.get((m, "gpecnet-batch"), {}), med.get((m, "ort"), {})
        for case, label in CASES:
            if case not in o:
                continue
            rb = o[case] / b[case] if case in b else float("nan")
            rs = o[case] / g[case] if case in g else float("nan")
            lines.append(f"| {m} | {label} | {fmt_s(g.get(case, float('nan')))} | "
                         f"{fmt_s(b.get(case, float('nan')))} | {fmt_s(o[case])} | "
                         f"**{rb:.2f}** ({rs:.2f}) |")
    lines.append("")
    for m in models:
        worst = {}
        for diffs, ok, tol in agree.get(m, []):
            for k, v in diffs.items():
                worst[k] = max(worst.get(k, 0.0), v)
        if worst:
            parts = ", ".join(f"{k} {v:.1e}" for k, v in worst.items())
            lines.append(f"- {m}: onnxruntime vs gpecnet-core on every test window, max abs "
                         f"difference (tolerance {tol:g}, metres and probabilities): {parts}.")
    lines.append(END)
    block = "\n".join(lines)
    print(block)
    for path, before in ((a.doc, "## Inference (endpoint path)"), (a.readme, "<!-- peers:begin -->")):
        if not path:
            continue
        with open(path) as f:
            text = f.read()
        with open(path, "w") as f:
            f.write(replace(text, block, before))
    return 0


if __name__ == "__main__":
    sys.exit(main())
