#!/usr/bin/env python3
"""Draws runs' mean training return against slot-steps beside the original's published points
and reference lines, as one SVG.
Usage: bench/curve_vs_original.py OUT.svg TITLE [--run LABEL=METRICS_CSV ...]
           [--orig LABEL=STEPS:RETURN,STEPS:RETURN,...] [--line LABEL=RETURN ...]
e.g.   bench/curve_vs_original.py curve.svg "hand_over" --run ppo=ppo/metrics.csv \\
           --run sac=sac/metrics.csv --orig "original PPO=2e6:3.6,10e6:17.6" \\
           --line "the original's final return=30.8\""""
import argparse, os, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from metrics_io import read_metrics  # noqa: E402  (plain or .xz)

COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf"]


def pair(text):
    label, _, value = text.partition("=")
    if not value:
        raise argparse.ArgumentTypeError(f"expected LABEL=VALUE, got '{text}'")
    return label, value


ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
ap.add_argument("out")
ap.add_argument("title")
ap.add_argument("--run", type=pair, action="append", default=[])
ap.add_argument("--orig", type=pair, action="append", default=[])
ap.add_argument("--line", type=pair, action="append", default=[])
args = ap.parse_args()

runs = []
for label, path in args.run:
    rows = [r for r in read_metrics(path) if r["return"] != ""]
    steps = "steps" if rows and "steps" in rows[0] else "slot_steps"  # examples/ppo_torch.py's
    runs.append((label, [(float(r[steps]), float(r["return"])) for r in rows]))
origs = [(label, [tuple(float(x) for x in p.split(":")) for p in pts.split(",")])
         for label, pts in args.orig]
lines = [(label, float(v)) for label, v in args.line]

allpts = [p for _, pts in runs + origs for p in pts]
W, H, L, R, T, B = 760, 440, 60, 20, 40, 50
xmax = max([s for s, _ in allpts] + [1])
ymin = min([0] + [v for _, v in allpts] + [v for _, v in lines])
ymax = max([1] + [v for _, v in allpts] + [v for _, v in lines]) * 1.05
X = lambda s: L + (W - L - R) * s / xmax
Y = lambda v: H - B - (H - T - B) * (v - ymin) / (ymax - ymin)
svg = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" '
       f'font-family="sans-serif" font-size="12">',
       f'<rect width="{W}" height="{H}" fill="white"/>',
       f'<text x="{W / 2}" y="22" text-anchor="middle" font-size="14">{args.title}</text>']
for i in range(6):  # axes and grid
    v = ymin + (ymax - ymin) * i / 5
    s = xmax * i / 5
    svg.append(f'<line x1="{L}" x2="{W - R}" y1="{Y(v):.1f}" y2="{Y(v):.1f}" stroke="#ddd"/>')
    svg.append(f'<text x="{L - 6}" y="{Y(v) + 4:.1f}" text-anchor="end">{v:.1f}</text>')
    svg.append(f'<text x="{X(s):.1f}" y="{H - B + 16}" text-anchor="middle">'
               f'{s / 1e6:.1f}M</text>')
svg.append(f'<text x="{W / 2}" y="{H - 12}" text-anchor="middle">slot-steps</text>')
svg.append(f'<text x="16" y="{H / 2}" transform="rotate(-90 16 {H / 2})" '
           f'text-anchor="middle">mean training return</text>')
for label, v in lines:
    svg.append(f'<line x1="{L}" x2="{W - R}" y1="{Y(v):.1f}" y2="{Y(v):.1f}" stroke="#999" '
               f'stroke-dasharray="5,4"/>')
    svg.append(f'<text x="{W - R - 4}" y="{Y(v) - 5:.1f}" text-anchor="end" fill="#666">'
               f'{label} {v:g}</text>')
legend = []
for i, (label, pts) in enumerate(runs):
    c = COLORS[i % len(COLORS)]
    svg.append(f'<polyline points="{" ".join(f"{X(s):.1f},{Y(v):.1f}" for s, v in pts)}" '
               f'fill="none" stroke="{c}" stroke-width="1.5"/>')
    legend.append((label, c, ""))
for label, pts in origs:
    svg.append(f'<polyline points="{" ".join(f"{X(s):.1f},{Y(v):.1f}" for s, v in pts)}" '
               f'fill="none" stroke="#d62728" stroke-width="1.5" stroke-dasharray="4,3"/>')
    svg += [f'<circle cx="{X(s):.1f}" cy="{Y(v):.1f}" r="4" fill="#d62728"/>' for s, v in pts]
    legend.append((label, "#d62728", ' stroke-dasharray="4,3"'))
for i, (label, c, dash) in enumerate(legend):
    y = T + 10 + 18 * i
    svg.append(f'<line x1="{L + 10}" x2="{L + 40}" y1="{y}" y2="{y}" stroke="{c}" '
               f'stroke-width="2"{dash}/><text x="{L + 46}" y="{y + 4}">{label}</text>')
svg.append("</svg>")
open(args.out, "w").write("\n".join(svg) + "\n")
