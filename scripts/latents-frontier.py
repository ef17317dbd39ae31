#!/usr/bin/env python3
"""latents-frontier.py CSV SVG: the minFDE / cost frontier of docs/latents.md as an SVG.

CSV columns: label, macs, val_mean, val_std (metres; std 0 for single numbers). Each row is
a point at x = MACs per pedestrian (K = 20 endpoints and the point forecast, log scale) and
y = validation minFDE, with a ±std bar. Standard library only.
"""
import csv
import math
import sys

rows = []
with open(sys.argv[1]) as f:
    for r in csv.DictReader(f):
        rows.append((r["label"], float(r["macs"]), float(r["val_mean"]), float(r["val_std"])))

W, H, L, R, T, B = 720, 420, 70, 20, 30, 50
xs = [math.log10(m) for _, m, _, _ in rows]
ys = [v for _, _, v, _ in rows]
x0, x1 = math.floor(min(xs) * 10) / 10 - 0.05, math.ceil(max(xs) * 10) / 10 + 0.05
y0 = math.floor((min(ys) - 0.02) * 50) / 50
y1 = math.ceil((max(ys) + 0.02) * 50) / 50


def px(x):
    return L + (x - x0) / (x1 - x0) * (W - L - R)


def py(y):
    return H - B - (y - y0) / (y1 - y0) * (H - T - B)


out = [
    f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" font-size="12">',
    f'<rect width="{W}" height="{H}" fill="white"/>',
    f'<line x1="{L}" y1="{H - B}" x2="{W - R}" y2="{H - B}" stroke="black"/>',
    f'<line x1="{L}" y1="{T}" x2="{L}" y2="{H - B}" stroke="black"/>',
    f'<text x="{(L + W - R) / 2}" y="{H - 12}" text-anchor="middle">MACs per pedestrian (K = 20 endpoints + point forecast), log scale</text>',
    f'<text x="16" y="{(T + H - B) / 2}" transform="rotate(-90 16 {(T + H - B) / 2})" text-anchor="middle">validation minFDE (m), mean ± std of 3 seeds</text>',
]
for e in range(int(math.floor(x0)), int(math.ceil(x1)) + 1):
    for m in (1, 2, 5):
        v = math.log10(m * 10**e)
        if x0 <= v <= x1:
            out.append(f'<line x1="{px(v):.1f}" y1="{H - B}" x2="{px(v):.1f}" y2="{H - B + 5}" stroke="black"/>')
            out.append(f'<text x="{px(v):.1f}" y="{H - B + 18}" text-anchor="middle">{m * 10**e:,}</text>')
y = y0
while y <= y1 + 1e-9:
    out.append(f'<line x1="{L - 5}" y1="{py(y):.1f}" x2="{W - R}" y2="{py(y):.1f}" stroke="#ddd"/>')
    out.append(f'<text x="{L - 8}" y="{py(y) + 4:.1f}" text-anchor="end">{y:.2f}</text>')
    y += 0.02
for label, m, v, s in rows:
    x, yv = px(math.log10(m)), py(v)
    if s > 0:
        out.append(f'<line x1="{x:.1f}" y1="{py(v - s):.1f}" x2="{x:.1f}" y2="{py(v + s):.1f}" stroke="#36c"/>')
    out.append(f'<circle cx="{x:.1f}" cy="{yv:.1f}" r="4" fill="#36c"/>')
    out.append(f'<text x="{x + 7:.1f}" y="{yv - 6:.1f}">{label}</text>')
out.append("</svg>")
with open(sys.argv[2], "w") as f:
    f.write("\n".join(out) + "\n")
