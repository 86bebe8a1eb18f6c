#!/usr/bin/env python3
"""Draws a run's mean training return against slot-steps beside the original's published points
(the mean of its 10-seed PPO training returns), as one SVG.
Usage: bench/curve_vs_original.py METRICS_CSV OUT.svg TITLE TARGET STEPS:RETURN [STEPS:RETURN ...]
e.g.   bench/curve_vs_original.py run/metrics.csv curve.svg "hand_over" 30.8 2e6:3.6 10e6:17.6"""
import csv, sys

path, out, title, target = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
orig = [tuple(float(x) for x in p.split(":")) for p in sys.argv[5:]]
rows = [r for r in csv.DictReader(open(path)) if r["return"] != ""]
ours = [(float(r["steps"]), float(r["return"])) for r in rows]

W, H, L, R, T, B = 720, 420, 60, 20, 40, 50
xmax = max([s for s, _ in ours] + [s for s, _ in orig] + [1])
ymin = min([0] + [v for _, v in ours] + [v for _, v in orig])
ymax = max([target] + [v for _, v in ours] + [v for _, v in orig]) * 1.05
X = lambda s: L + (W - L - R) * s / xmax
Y = lambda v: H - B - (H - T - B) * (v - ymin) / (ymax - ymin)
svg = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" font-size="12">',
       f'<rect width="{W}" height="{H}" fill="white"/>',
       f'<text x="{W / 2}" y="22" text-anchor="middle" font-size="14">{title}</text>']
for i in range(6):  # axes and grid
    v = ymin + (ymax - ymin) * i / 5
    s = xmax * i / 5
    svg.append(f'<line x1="{L}" x2="{W - R}" y1="{Y(v):.1f}" y2="{Y(v):.1f}" stroke="#ddd"/>')
    svg.append(f'<text x="{L - 6}" y="{Y(v) + 4:.1f}" text-anchor="end">{v:.1f}</text>')
    svg.append(f'<text x="{X(s):.1f}" y="{H - B + 16}" text-anchor="middle">{s / 1e6:.0f}M</text>')
svg.append(f'<text x="{W / 2}" y="{H - 12}" text-anchor="middle">slot-steps</text>')
svg.append(f'<text x="16" y="{H / 2}" transform="rotate(-90 16 {H / 2})" text-anchor="middle">mean training return</text>')
svg.append(f'<line x1="{L}" x2="{W - R}" y1="{Y(target):.1f}" y2="{Y(target):.1f}" stroke="#999" stroke-dasharray="5,4"/>')
svg.append(f'<text x="{W - R - 4}" y="{Y(target) - 5:.1f}" text-anchor="end" fill="#666">the original\'s final return {target}</text>')
pts = " ".join(f"{X(s):.1f},{Y(v):.1f}" for s, v in ours)
svg.append(f'<polyline points="{pts}" fill="none" stroke="#1f77b4" stroke-width="1.5"/>')
opts = " ".join(f"{X(s):.1f},{Y(v):.1f}" for s, v in orig)
svg.append(f'<polyline points="{opts}" fill="none" stroke="#d62728" stroke-width="1.5" stroke-dasharray="4,3"/>')
for s, v in orig:
    svg.append(f'<circle cx="{X(s):.1f}" cy="{Y(v):.1f}" r="4" fill="#d62728"/>')
svg.append(f'<line x1="{L + 10}" x2="{L + 40}" y1="{T + 10}" y2="{T + 10}" stroke="#1f77b4" stroke-width="2"/>'
           f'<text x="{L + 46}" y="{T + 14}">bidex, GPU path</text>')
svg.append(f'<line x1="{L + 10}" x2="{L + 40}" y1="{T + 28}" y2="{T + 28}" stroke="#d62728" stroke-dasharray="4,3" stroke-width="2"/>'
           f'<text x="{L + 46}" y="{T + 32}">original PPO, mean of 10 seeds</text>')
svg.append("</svg>")
open(out, "w").write("\n".join(svg) + "\n")
