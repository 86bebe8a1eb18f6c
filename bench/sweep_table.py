#!/usr/bin/env python3
"""The PPO sweep's table and figure from its results folders (bench/sweep_run.sh collect):
prints one markdown table and writes OUT/sweep-curves.svg and .png (rsvg-convert), the
learning curves in a grid, each with the original's published final, the random policy's
return and the mean action's evaluation. With several folders (one per lease), a run of a later
folder replaces the run of the same name and slot count in an earlier one. A suite's run in a
folder (MT4, MT20: bench/suite_train_table.py) is left out.
Usage: bench/sweep_table.py DIR [DIR...] [--out OUT (default: the last DIR)]
                            [--references configs/registry/references.yaml]"""
import argparse, json, os, shutil, subprocess, sys

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from atomic_io import replacing, write_text  # noqa: E402
from sweep_collect import comparable, is_suite, rows_of  # noqa: E402  (their one definition)

COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd"]
ORIGINAL_CURVES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "sweep",
                               "original_ppo_curves.json")


def value(v):
    return v["value"] if isinstance(v, dict) else v


def curve(path):
    """(slot-steps, training return, the same without goal bonus) per update."""
    return [(float(r["steps"]), float(r["return"]), comparable(r)) for r in rows_of(path)]


def fmt(v, digits=1):
    return "" if v is None else f"{v:,.{digits}f}"


SWEEP_SLOTS = 16384


def run_env(t):
    """the env section of the config.yaml the run's folder keeps ({} where absent)"""
    path = os.path.join(t["dir"], t["run"], "config.yaml")
    if not os.path.exists(path):
        return {}
    return (yaml.safe_load(open(path)) or {}).get("env") or {}


def slots(t):
    """the run's slot count (the sweep's where its folder keeps no config.yaml)"""
    return int(run_env(t).get("slots", SWEEP_SLOTS))


def label(t):
    """the task, the task YAML and training overrides of bench/sweep/ that the run used, and its
    slots where they are its own (the task's section of configs/train/ppo.yaml)"""
    # the sweep's task YAML, else the training YAML of the task's section (a training aid such as
    # re_orientation's) that the run's config.yaml names
    config = t.get("task_config") or run_env(t).get("task_config")
    files = [config] if config else []
    # a list of every overrides file; a string in sweep.json files collected before it was one
    overrides = t.get("overrides") or []
    files += [overrides] if isinstance(overrides, str) else overrides
    names = [os.path.splitext(os.path.basename(f))[0] for f in files]
    if not t.get("overrides") and slots(t) != SWEEP_SLOTS:
        names.append(f"{slots(t):,} slots")
    return t["task"] + (f" ({', '.join(names)})" if names else "")


def table(runs, random):
    head = ("| task | seed | slot-steps | wall | median slot-steps/s | training return, last 10M "
            "(without goal bonus) | training success, last 10M | mean action: return | success | length | faults | random | "
            "original's final | first reached it at |")
    lines = [head, "|" + "---|" * 14]
    for t in runs:
        e = t["eval"] or {}
        ret = fmt(t["train_return_last_10M"])
        if t["train_return_no_bonus_last_10M"] is not None and \
                abs(t["train_return_no_bonus_last_10M"] - (t["train_return_last_10M"] or 0)) > 1e-9:
            ret += f" ({fmt(t['train_return_no_bonus_last_10M'])})"
        if t["still_rising"]:
            ret += ", rising"
        reached = ""
        if t["original_ppo_final"] is not None:
            a = t["reached_at"]
            reached = f"{a['slot_steps'] / 1e6:.1f}M, {a['wall_s']:.0f} s" if a else "not reached"
        lines.append(
            f"| {label(t)} | {t['seed']} | {t['slot_steps'] / 1e6:.1f}M | {t['wall_s']:.0f} s | "
            f"{fmt(t['train_fps_median'], 0)} | {ret} | "
            f"{fmt(t.get('train_success_last_10M'), 2)} | {fmt(e.get('return'))} | "
            f"{fmt(e.get('success'), 2)} | {fmt(e.get('length'), 0)} | "
            f"{'' if e.get('faults') is None else e['faults']} | {fmt(random.get(t['task']))} | "
            f"{fmt(t['original_ppo_final'])} | {reached} |")
    return "\n".join(lines)


def figure(runs, random, out):
    tasks = list(dict.fromkeys(t["task"] for t in runs))
    cols = 5
    rows = (len(tasks) + cols - 1) // cols
    PW, PH, L, R, T, B = 250, 190, 46, 10, 34, 30
    W, H = cols * PW, rows * PH + 40
    svg = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" '
           f'font-family="sans-serif" font-size="10">', f'<rect width="{W}" height="{H}" fill="white"/>',
           f'<text x="{W / 2}" y="18" text-anchor="middle" font-size="12">PPO on every task: training '
           f'return against slot-steps. Grey: the original\'s 10-seed mean; dashed: its final; '
           f'dotted: random; dot: the mean action\'s evaluation; light: without the goal bonus'
           f'</text>']
    original = json.load(open(ORIGINAL_CURVES))["tasks"]
    for i, task in enumerate(tasks):
        ox, oy = (i % cols) * PW, 30 + (i // cols) * PH
        mine = [t for t in runs if t["task"] == task]
        curves = [(t, curve(os.path.join(t["dir"], t["run"], "metrics.csv"))) for t in mine]
        ys = [p[1] for _, c in curves for p in c] + [p[2] for _, c in curves for p in c]
        ys += [v for v in (random.get(task), mine[0]["original_ppo_final"]) if v is not None]
        ys += [t["eval"]["return"] for t in mine if t["eval"]]
        xmax = max([p[0] for _, c in curves for p in c] + [5e7])
        orig = [(m * 1e6, v) for m, v in original.get(task, {}).get("points", []) if m * 1e6 <= xmax]
        ys += [v for _, v in orig]
        ymin, ymax = min(ys + [0]), max(ys + [1])
        ymax += 0.05 * (ymax - ymin)
        X = lambda s: ox + L + (PW - L - R) * s / xmax
        Y = lambda v: oy + PH - B - (PH - T - B) * (v - ymin) / (ymax - ymin)
        svg.append(f'<text x="{ox + PW / 2}" y="{oy + 14}" text-anchor="middle" font-size="11">'
                   f'{task}</text>')
        svg.append(f'<rect x="{ox + L}" y="{oy + T}" width="{PW - L - R}" height="{PH - T - B}" '
                   f'fill="none" stroke="#bbb"/>')
        for k in range(3):
            v = ymin + (ymax - ymin) * k / 2
            s = xmax * k / 2
            svg.append(f'<text x="{ox + L - 3}" y="{Y(v) + 3:.1f}" text-anchor="end">{v:.4g}</text>')
            svg.append(f'<text x="{X(s):.1f}" y="{oy + PH - B + 12}" text-anchor="middle">'
                       f'{s / 1e6:.0f}M</text>')
        for v, dash in ((mine[0]["original_ppo_final"], "5,3"), (random.get(task), "1,3")):
            if v is not None:
                svg.append(f'<line x1="{ox + L}" x2="{ox + PW - R}" y1="{Y(v):.1f}" y2="{Y(v):.1f}" '
                           f'stroke="#555" stroke-dasharray="{dash}"/>')
        if orig:
            pts = " ".join(f"{X(s):.1f},{Y(v):.1f}" for s, v in orig)
            svg.append(f'<polyline points="{pts}" fill="none" stroke="#999" stroke-width="2.5"/>')
        for j, (t, c) in enumerate(curves):
            color = COLORS[j % len(COLORS)]
            if not c:
                continue
            if any(abs(p[1] - p[2]) > 1e-9 for p in c):
                pts = " ".join(f"{X(s):.1f},{Y(v):.1f}" for s, _, v in c)
                svg.append(f'<polyline points="{pts}" fill="none" stroke="{color}" '
                           f'stroke-opacity="0.35"/>')
            pts = " ".join(f"{X(s):.1f},{Y(v):.1f}" for s, v, _ in c)
            svg.append(f'<polyline points="{pts}" fill="none" stroke="{color}"/>')
            if t["eval"]:
                svg.append(f'<circle cx="{X(c[-1][0]):.1f}" cy="{Y(t["eval"]["return"]):.1f}" r="3" '
                           f'fill="{color}"/>')
        e = [t["eval"] for t in mine if t["eval"]]
        label = ("success " + ", ".join(f"{x['success']:.2f}" for x in e) if e
                 else f"stopped at {max(t['slot_steps'] for t in mine) / 1e6:.1f}M, not evaluated")
        svg.append(f'<text x="{ox + PW / 2}" y="{oy + PH - 4}" text-anchor="middle" fill="#444">'
                   f'{label}</text>')
    svg.append("</svg>")
    write_text(out + ".svg", "\n".join(svg))
    if shutil.which("rsvg-convert"):
        with replacing(out + ".png") as tmp:
            subprocess.run(["rsvg-convert", "-b", "white", "-o", tmp, out + ".svg"], check=True)
    else:
        print("rsvg-convert not found (apt-get install librsvg2-bin): wrote the SVG only",
              file=sys.stderr)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dirs", nargs="+", metavar="DIR")
    ap.add_argument("--out")
    ap.add_argument("--references", default="configs/registry/references.yaml")
    a = ap.parse_args()
    byname = {}
    for d in a.dirs:
        path = os.path.join(d, "sweep.json")
        if not os.path.exists(path):
            sys.exit(f"sweep_table: {path} not found (bench/sweep_run.sh collect writes it)")
        for t in json.load(open(path))["runs"]:
            if is_suite(t["task"]):
                continue
            t = dict(t, dir=d)
            byname[(t["run"], slots(t))] = t  # a later lease's run replaces it
    runs = list(byname.values())
    if not os.path.exists(a.references):
        sys.exit(f"sweep_table: --references {a.references} not found (run from the repository "
                 "root, or name the file)")
    refs = yaml.safe_load(open(a.references)) or {}
    random = {k: value(v) for k, v in ((refs.get("random") or {}).get("values") or {}).items()}
    runs.sort(key=lambda t: (t["original_ppo_final"] is None, t["task"], t["seed"]))
    print(table(runs, random))
    out = a.out or a.dirs[-1]
    os.makedirs(out, exist_ok=True)
    figure(runs, random, os.path.join(out, "sweep-curves"))


if __name__ == "__main__":
    main()
