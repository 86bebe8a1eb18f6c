#!/usr/bin/env python3
"""A multi-task run's figures per task (issue 37): from its metrics.csv, the mean return and success
rate of each task over the updates in the last WINDOW slot-steps in which its episodes ended, and
the return normalised by the registry's references (random 0, ground truth 1) of the member's
task id, as the registry normalises (a member labelled hand_over that plays hand_over_free takes
hand_over_free's references, none where it has none); where the folder
holds eval.json (bidex eval --run DIR --json), the mean action's return, success and normalised
score beside them, and under the table the mean action's mean return over the tasks, also with
the suite's reward scales (the paper's metric).

With --curve, below the table: the training normalised mean over the tasks in each successive
WINDOW of slot-steps from the start (whether and how fast the run still rises).

The training figures come from sampled actions. Each update's per-task mean counts once:
metrics.csv does not keep a task's episode count.
The references and the suites' files (configs/) are found from the source tree the script is
in, wherever it runs.
Usage: bench/suite_train_table.py RUN_DIR [--window 1e7] [--curve]
                                  [--references configs/registry/references.yaml]
"""
import argparse, json, math, os, sys

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sweep_table import value  # noqa: E402  (a references.yaml value, plain or with its source)
from metrics_io import metrics_exists, read_metrics  # noqa: E402  (plain or .xz)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # the source tree


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


def members(run):
    """({label: task id}, {label: reward scale}) of the run's suite (run.json's suite,
    configs/suites/SUITE.yaml), or ({}, {})"""
    info = os.path.join(run, "run.json")
    suite = (json.load(open(info)).get("suite") or "") if os.path.exists(info) else ""
    path = suite if suite.endswith(".yaml") else os.path.join(ROOT, "configs", "suites", f"{suite}.yaml")
    if not suite or not os.path.exists(path):
        return {}, {}
    train = (yaml.safe_load(open(path)) or {}).get("train") or []
    label = [m.get("label", m["task"]) for m in train]
    return ({l: m["task"] for l, m in zip(label, train)},
            {l: float(m.get("reward_scale", 1.0)) for l, m in zip(label, train)})


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("run")
    ap.add_argument("--window", type=float, default=1e7)
    ap.add_argument("--curve", action="store_true",
                    help="also the normalised training mean in each window from the start")
    ap.add_argument("--references", default=os.path.join(ROOT, "configs", "registry", "references.yaml"))
    a = ap.parse_args()
    path = os.path.join(a.run, "metrics.csv")
    if not metrics_exists(path):
        sys.exit(f"suite_train_table: {path} not found, nor {path}.xz (a run folder of bidex train --suite)")
    if not os.path.exists(a.references):
        sys.exit(f"suite_train_table: --references {a.references} not found")
    rows = read_metrics(path)
    tasks = [c[len("return_"):] for c in (rows[0] if rows else {}) if c.startswith("return_")]
    if not tasks:
        sys.exit(f"suite_train_table: {path} has no return_TASK columns (not a suite run)")
    refs = yaml.safe_load(open(a.references)) or {}
    task_of, scale_of = members(a.run)
    random, truth = section(refs, "random"), section(refs, "ground_truth")
    evaluated = {}
    eval_path = os.path.join(a.run, "eval.json")
    if os.path.exists(eval_path):
        try:
            evaluated = {t["label"]: t for t in json.load(open(eval_path))["per_task"]}
        except (ValueError, KeyError, TypeError) as e:
            sys.exit(f"suite_train_table: {eval_path}: expected bidex eval's JSON with per_task "
                     f"entries (label, mean_return, success_rate): {e!r}")
    end = float(rows[-1]["steps"])
    recent = [r for r in rows if float(r["steps"]) > end - a.window]
    print(f"{a.run}: {len(rows)} updates, {end / 1e6:.1f}M slot-steps, {float(rows[-1]['wall_s']):.0f} s; "
          f"median training rate {sorted(float(r['fps']) for r in rows)[len(rows) // 2]:,.0f} "
          f"slot-steps/s; the last {a.window / 1e6:g}M slot-steps ({len(recent)} updates)")
    print()
    head = "| task | training return | training success | random | ground truth | normalised |"
    rule = "|---|---|---|---|---|---|"
    if evaluated:
        head += " mean action: return | success | normalised |"
        rule += "---|---|---|"
    print(head)
    print(rule)

    def normalised(ret, lo, hi):
        return None if None in (ret, lo, hi) or hi == lo else (ret - lo) / (hi - lo)

    def task_norm(t, window_rows):
        """(mean training return, its normalised score) of task t over window_rows"""
        ret = mean(num(r[f"return_{t}"]) for r in window_rows)
        return ret, normalised(ret, random.get(task_of.get(t, t)), truth.get(task_of.get(t, t)))

    norms, succs, e_norms, e_succs = [], [], [], []
    for t in tasks:
        ret, norm = task_norm(t, recent)
        suc = mean(num(r.get(f"success_{t}")) for r in recent)
        lo, hi = random.get(task_of.get(t, t)), truth.get(task_of.get(t, t))
        norms.append(norm)
        succs.append(suc)
        name = t if task_of.get(t, t) == t else f"{t} ({task_of[t]})"
        line = f"| {name} | {fmt(ret)} | {fmt(suc)} | {fmt(lo)} | {fmt(hi)} | {fmt(norm)} |"
        if evaluated:
            e = evaluated.get(t) or {}
            e_ret, e_suc = num(e.get("mean_return")), num(e.get("success_rate"))
            e_norm = normalised(e_ret, lo, hi)
            e_norms.append(e_norm)
            e_succs.append(e_suc)
            line += f" {fmt(e_ret)} | {fmt(e_suc)} | {fmt(e_norm)} |"
        print(line)
    n = [x for x in norms if x is not None]
    line = f"| **mean** | | {fmt(mean(succs))} | | | **{fmt(mean(n))}** ({len(n)} of {len(tasks)} tasks) |"
    if evaluated:
        en = [x for x in e_norms if x is not None]
        line += f" | {fmt(mean(e_succs))} | **{fmt(mean(en))}** ({len(en)} of {len(tasks)}) |"
    print(line)
    if evaluated:
        rets = [num((evaluated.get(t) or {}).get("mean_return")) for t in tasks]
        scaled = [None if r is None else r * scale_of.get(t, 1.0) for t, r in zip(tasks, rets)]
        print()
        print(f"The mean action's mean return over the {len(tasks)} tasks: {fmt(mean(rets))}; with "
              f"the suite's reward scales (the paper's metric): {fmt(mean(scaled))}. Its normalised "
              f"mean with each task's score capped at 1 (a task past its ground truth counting as "
              f"1): {fmt(mean([min(x, 1.0) for x in en]))}.")
    if a.curve:
        print()
        print("| slot-steps | updates | training normalised mean |")
        print("|---|---|---|")
        lo = 0.0
        while lo < end:
            w = [r for r in rows if lo <= float(r["steps"]) < lo + a.window]
            n = [x for x in (task_norm(t, w)[1] for t in tasks) if x is not None]
            if w:
                print(f"| {lo / 1e6:g}-{(lo + a.window) / 1e6:g}M | {len(w)} | {fmt(mean(n))} "
                      f"({len(n)} of {len(tasks)}) |")
            lo += a.window


if __name__ == "__main__":
    main()
