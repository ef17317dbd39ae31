#!/usr/bin/env python3
"""Writes docs/peers.md from the JSON lines bench.sh collected: medians over rounds, ratios
= peer time / gpecnet time (> 1: gpecnet faster).

    python scripts/peers/report.py --results target/peers/results.jsonl \
        --checks target/peers/check-*.json --out docs/peers.md --command "scripts/peers/bench.sh"
"""

import argparse
import datetime
import json
import platform
import statistics
import subprocess
import sys
from collections import defaultdict

CASES = [
    ("ped_k1", "one pedestrian, K = 1"),
    ("ped_k20", "one pedestrian, K = 20"),
    ("ped_k200", "one pedestrian, K = 200"),
    ("ped_k1000", "one pedestrian, K = 1,000"),
    ("set_k20", "whole SDD test set (2,829 windows), K = 20"),
]


def fmt_t(s):
    if s is None:
        return "–"
    if s >= 1:
        return f"{s:.2f} s"
    if s >= 1e-3:
        return f"{s * 1e3:.2f} ms"
    return f"{s * 1e6:.1f} µs"


def ratio(a, b):
    return "–" if a is None or b is None else f"{a / b:.2f}"


def cpu():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def git(*args):
    try:
        return subprocess.run(["git", *args], capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "?"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--results", required=True)
    ap.add_argument("--checks", nargs="*", default=[])
    ap.add_argument("--out", required=True)
    ap.add_argument("--command", default="scripts/peers/bench.sh")
    ap.add_argument("--note", default="", help="extra paragraph under the machine line")
    ap.add_argument("--readme", help="replace the table between <!-- peers:begin --> and "
                    "<!-- peers:end --> in this file")
    a = ap.parse_args()

    infer = defaultdict(list)  # (model, impl, case) -> [seconds]
    train = defaultdict(list)  # (config, impl, threads) -> [seconds]
    versions, rounds, n_train, loads = {}, defaultdict(int), {}, []
    with open(a.results) as f:
        for line in f:
            line = line.strip()
            if not line.startswith("{"):
                continue
            r = json.loads(line)
            if "loadavg" in r:
                loads.append(r["loadavg"])
                continue
            if "version" in r:
                versions[r["impl"]] = r["version"]
            if "seconds_per_call" in r:
                rounds[(r["model"], r["impl"])] += 1
                for case, s in r["seconds_per_call"].items():
                    infer[(r["model"], r["impl"], case)].append(s)
            elif "median" in r:
                cfg = r["config"].rsplit("/", 1)[-1].removesuffix(".toml")
                train[(cfg, r["impl"], r["threads"])].extend(r["epoch_seconds"])
                n_train[cfg] = (r["n_train"], r["batch_size"])

    def med(key, table):
        v = table.get(key)
        return statistics.median(v) if v else None

    models = sorted({k[0] for k in infer}, key=lambda m: (m != "sdd-small", m))
    lines = []
    w = lines.append
    w("# gpecnet next to onnxruntime and PyTorch")
    w("")
    w("Side by side on one machine, one thread each, same weights: onnxruntime runs the ONNX "
      "file `gpecnet onnx --endpoint-only` writes, PyTorch eager runs the same graph built from "
      "its initializers (`scripts/peers/peers.py`), and both are fed the core's own network "
      "inputs and latents (`peer_bench dump`). Runs are interleaved (gpecnet, onnxruntime, "
      "PyTorch, next model, next round); each number is the median over rounds of each "
      "process's median per call. **Ratio = peer time / gpecnet time: above 1.0 gpecnet is "
      "faster.** Not run in CI; wall-clock numbers live here, never in tests.")
    w("")
    w(f"- Command: `{a.command}` (produced this file)")
    dirty = [ln for ln in git("status", "--porcelain", "--untracked-files=no").splitlines() if ln]
    w(f"- Commit: `{git('rev-parse', '--short', 'HEAD')}` "
      f"({git('log', '-1', '--format=%s')[:100]}...)"
      + (f", built from the working tree with {len(dirty)} uncommitted tracked files" if dirty
         else "")
      + f"; {datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}")
    w(f"- Machine: {cpu()}, {platform.machine()}, {len(__import__('os').sched_getaffinity(0))} "
      f"cores visible, Linux {platform.release()}; python {platform.python_version()}; "
      + ", ".join(sorted(set(versions.values()))))
    w("- Threads: gpecnet single-threaded; `OMP_NUM_THREADS=1`, onnxruntime "
      "`intra_op_num_threads=1` (sequential execution), `torch.set_num_threads(1)`; training "
      "at the stated thread count (`threads` of the trainer config / `torch.set_num_threads`)")
    if loads:
        w(f"- Load: 1-minute load average {min(loads):.1f}–{max(loads):.1f} during the timed "
          f"runs (other jobs shared the machine; absolute times are noisier than ratios)")
    if a.note:
        w(f"- {a.note}")
    w("")
    w("## Agreement with the core")
    w("")
    w("`scripts/peers/check.py` (run by bench.sh on each model before timing): every output of "
      "the full graph (`gpecnet onnx`, all heads) against `gpecnet-core` (libm sine) on the whole "
      "SDD test set, K = 20, and on test window 0 at K = 1,000; outputs mapped to pixels as the "
      "core maps them. Tolerance: **0.01 px** (the check fails above it); measured:")
    w("")
    w("| model | output | onnxruntime max abs diff | PyTorch max abs diff |")
    w("|---|---|---|---|")
    for path in a.checks:
        with open(path) as f:
            c = json.load(f)
        keys = list(c.get("onnxruntime", {}))
        for k in keys:
            t = c.get("pytorch", {}).get(k)
            w(f"| {c['model']} | {k} | {c['onnxruntime'][k]:.1e} px | "
              + (f"{t:.1e} px" if t is not None else "–") + " |")
    w("")
    w("Not bit for bit: onnxruntime and PyTorch sum in their own order, with fused "
      "multiply-adds, and use their own `sin`; the core's arithmetic contract (left to right, "
      "separate multiply and add, libm `sinf`) is what makes it bit-exact across x86 and "
      "Cortex-M.")
    w("")
    w("## Inference (endpoint path)")
    w("")
    w("gpecnet: `Predictor::predict_samples` (scalar engine, one window at a time) and "
      "`HostBatchPredictor` (`gpecnet_core::batch`, 8 lanes; `predict_samples` for one "
      "pedestrian, `predict_samples_many` for the test set), checked bit-identical to each "
      "other before timing; both include the frame, the latent sampler (Box–Muller) and the "
      "mapping to pixels, which the peers get for free (precomputed latents). \"batched\" is "
      "the default (AVX2 where the CPU has it, chosen at run time); \"SSE2\" is the same "
      "batched path with `gpecnet_core::batch::set_wide_vectors(false)` (`peer_bench infer "
      "--sse2`), the same bits. Peers: one call "
      "of the graph on `x [n, 16]`, `z [n, K, 16]` (n = 1 for one pedestrian, 2,829 for the set).")
    w("")
    w("| model | case | gpecnet scalar | gpecnet batched, SSE2 | gpecnet batched | onnxruntime "
      "| PyTorch eager | ORT / scalar | ORT / batched | PyTorch / scalar | PyTorch / batched |")
    w("|---|---|---|---|---|---|---|---|---|---|---|")
    summary = []
    for m in models:
        for case, label in CASES:
            g = med((m, "gpecnet", case), infer)
            gb = med((m, "gpecnet-batch", case), infer)
            gs = med((m, "gpecnet-batch-sse2", case), infer)
            o = med((m, "ort", case), infer)
            t = med((m, "torch", case), infer)
            if g is None and o is None:
                continue
            w(f"| {m} | {label} | {fmt_t(g)} | {fmt_t(gs)} | {fmt_t(gb)} | {fmt_t(o)} | {fmt_t(t)} "
              f"| {ratio(o, g)} | **{ratio(o, gb)}** | {ratio(t, g)} | **{ratio(t, gb)}** |")
            summary.append((f"{label}, {m}", f"{ratio(o, gb)} ({ratio(o, g)})",
                            f"{ratio(t, gb)} ({ratio(t, g)})"))
    w("")
    w("Rounds: " + ", ".join(f"{m} {i} {n}" for (m, i), n in sorted(rounds.items())) + ".")
    if train:
        w("")
        w("## Training epoch")
        w("")
        w("gpecnet: `Trainer::train_epoch` (candle, the trainer's own Adam), one warm-up epoch "
          "then timed epochs. PyTorch eager: `scripts/peers/train_torch.py`, the same "
          "architecture, loss (endpoint MSE + KLD + trajectory MSE), batch size, Adam "
          "(PyTorch's, same lr) and the trainer's own training samples (`peer_bench "
          "train-data`), reading the loss back every batch as the trainer does.")
        w("")
        w("| config | samples / batch | threads | gpecnet | PyTorch eager | PyTorch / gpecnet "
          "| PyTorch, `OMP_WAIT_POLICY=PASSIVE` | its ratio |")
        w("|---|---|---|---|---|---|---|---|")
        for cfg in ("sdd-tiny", "sdd-small", "sdd-paper"):
            for th in (1, 2):
                g, t = med((cfg, "gpecnet", th), train), med((cfg, "torch", th), train)
                tp = med((cfg, "torch-passive", th), train)
                if g is None and t is None:
                    continue
                nt = n_train.get(cfg, ("?", "?"))
                w(f"| {cfg} | {nt[0]} / {nt[1]} | {th} | {fmt_t(g)} | {fmt_t(t)} "
                  f"| **{ratio(t, g)}** | {fmt_t(tp)} | {ratio(tp, g)} |")
                summary.append((f"training epoch, {cfg}, {th} thread{'s' if th > 1 else ''}",
                                "–", ratio(t, g) + (f" (PASSIVE: {ratio(tp, g)})" if tp else "")))
        w("")
        w("Epochs per cell: " + ", ".join(
            f"{c} {i} {th}t: {len(v)}" for (c, i, th), v in sorted(train.items())) + ".")
    notes = __import__("os").path.join(__import__("os").path.dirname(__file__), "notes.md")
    if __import__("os").path.exists(notes):
        with open(notes) as f:
            w("")
            w(f.read().rstrip())
    with open(a.out, "w") as f:
        f.write("\n".join(lines) + "\n")
    table = ["| case | vs onnxruntime: batched (scalar) | vs PyTorch eager: batched (scalar) |",
             "|---|---|---|"]
    table += [f"| {label} | {o} | {t} |" for label, o, t in summary]
    print("\n".join(table))
    if a.readme:
        with open(a.readme) as f:
            text = f.read()
        begin, end = "<!-- peers:begin -->", "<!-- peers:end -->"
        i, j = text.find(begin), text.find(end)
        if i < 0 or j < i:
            print(f"{a.readme}: no {begin} ... {end} block; not changed", file=sys.stderr)
            return 1
        block = (f"{begin}\nRatio = peer time / gpecnet time (> 1: gpecnet faster), one thread "
                 f"each unless stated, medians; gpecnet's batched host path (`gpecnet_core::batch`"
                 f") first, the scalar `Predictor` in brackets. `{a.command}`, "
                 f"{cpu()}, {datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%d')}"
                 f"; details, tolerances and why: `docs/peers.md`.\n\n" + "\n".join(table) + "\n")
        with open(a.readme, "w") as f:
            f.write(text[:i] + block + text[j:])
    return 0


if __name__ == "__main__":
    sys.exit(main())
