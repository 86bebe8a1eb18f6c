#!/usr/bin/env python3
"""A multi-task run's training figures per task (issue 37): from its metrics.csv, the mean return
and success rate of each task over the updates in the last WINDOW slot-steps in which its episodes
ended, and the return normalised by the registry's references (random 0, ground truth 1).

These are training figures (sampled actions), not the mean action's evaluation (bidex eval --run).
Each update's per-task mean counts once: metrics.csv does not keep a task's episode count.
Usage: bench/suite_train_table.py RUN_DIR [--window 1e7] [--references configs/registry/references.yaml]
"""
import argparse, csv, math, os, sys

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sweep_table import value  # noqa: E402  (a references.yaml value, plain or with its source)


def section(refs, name):
    return {k: value(v) for k, v in ((refs.get(name) or {}).get("values") or {}).items()}


def num(x):
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(v) else v


def mean(xs):
    xs = [x for x in xs if x is not None]
    return sum(xs) / len(xs) if xs else None


def fmt(x, digits=2):
    return "" if x is None else f"{x:,.{digits}f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("run")
    ap.add_argument("--window", type=float, default=1e7)
    ap.add_argument("--references", default="configs/registry/references.yaml")
    a = ap.parse_args()
    path = os.path.join(a.run, "metrics.csv")
    if not os.path.exists(path):
        sys.exit(f"suite_train_table: {path} not found (a run folder of bidex train --suite)")
    if not os.path.exists(a.references):
        sys.exit(f"suite_train_table: --references {a.references} not found")
    rows = list(csv.DictReader(open(path)))
    tasks = [c[len("return_"):] for c in (rows[0] if rows else {}) if c.startswith("return_")]
    if not tasks:
        sys.exit(f"suite_train_table: {path} has no return_TASK columns (not a suite run)")
    refs = yaml.safe_load(open(a.references)) or {}
    random, truth = section(refs, "random"), section(refs, "ground_truth")
    end = float(rows[-1]["steps"])
    recent = [r for r in rows if float(r["steps"]) > end - a.window]
    print(f"{a.run}: {len(rows)} updates, {end / 1e6:.1f}M slot-steps, {float(rows[-1]['wall_s']):.0f} s; "
          f"median training rate {sorted(float(r['fps']) for r in rows)[len(rows) // 2]:,.0f} "
          f"slot-steps/s; the last {a.window / 1e6:g}M slot-steps ({len(recent)} updates)")
    print()
    print("| task | training return | training success | random | ground truth | normalised |")
    print("|---|---|---|---|---|---|")
    norms, succs = [], []
    for t in tasks:
        ret = mean(num(r[f"return_{t}"]) for r in recent)
        suc = mean(num(r.get(f"success_{t}")) for r in recent)
        lo, hi = random.get(t), truth.get(t)
        norm = None if None in (ret, lo, hi) or hi == lo else (ret - lo) / (hi - lo)
        norms.append(norm)
        succs.append(suc)
        print(f"| {t} | {fmt(ret)} | {fmt(suc)} | {fmt(lo)} | {fmt(hi)} | {fmt(norm)} |")
    n = [x for x in norms if x is not None]
    print(f"| **mean** | | {fmt(mean(succs))} | | | **{fmt(mean(n))}** ({len(n)} of {len(tasks)} tasks) |")


if __name__ == "__main__":
    main()
