#!/usr/bin/env python3
"""Each task's time to its goal in the PPO sweep (issue 36's goals; issue 37's second answer to
"are tasks harder for infants harder for RL"), as configs/registry/time_to_goal.yaml, which the
registry loads and `bidex registry report age` draws against human age.

The goal: for the nine tasks whose ground truth is the original's published PPO final, the mean
training return (without bidex's goal bonus) of the last 100 episodes at or above it; for the
other eleven, whose ground truth is bidex's own PPO, the mean training success of the last 100
episodes at or above 0.8. Time: the slot-steps and wall seconds of the first update that met it
("by: training"). A run that never met it in training but whose final mean action did (over 256
episodes) counts at its last update ("by: evaluation", an upper bound); one that met neither is
"by: not_reached" at the slot-steps it trained (a lower bound).

The run of each task: seed 0 at the task's default, the one that trained furthest (a suite's
run in a folder, MT20 or ML20, is left out). Default: the
training settings of configs/train/ppo.yaml (the task's slots and minibatches, else the sweep's
16,384 and 16, and the other PPO settings of the task's section) and the task's YAML: its own at
its current version (run.json's task_version, against `bidex info`), the training YAML of the
task's section, or a sweep YAML whose terms equal today's default (EQUIVALENT).
Usage: bench/sweep_time_to_goal.py DIR [DIR...] [--bidex build/apps/bidex]
                                   [--out configs/registry/time_to_goal.yaml]"""
import argparse, json, os, subprocess, sys

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from atomic_io import atomic_open  # noqa: E402
from sweep_collect import ORIGINAL_PPO_FINAL, comparable, is_suite, num, recent, rows_of  # noqa: E402

SUCCESS_GOAL = 0.8
# sweep YAMLs whose terms are today's default of their task (each task's README says so)
EQUIVALENT = {"pour_water": "bench/sweep/pour_lift_steep.yaml",   # version 2
              "pen": "bench/sweep/pen_reach2.yaml",                # version 2
              "block_stack": "bench/sweep/block_stack_original.yaml",  # version 2
              # the terms of its training YAML, tasks/re_orientation/re_orientation_progress.yaml
              "re_orientation": "bench/sweep/reorient_progress100.yaml"}
GOAL_FROM_ORIGINAL = set(ORIGINAL_PPO_FINAL) - {"hand_over"}  # hand_over's ground truth is bidex's


def task_section(task):
    """the task's section of configs/train/ppo.yaml ({} when it has none)"""
    return yaml.safe_load(open("configs/train/ppo.yaml"))["per_task"].get(task) or {}


def default_training(task):
    """(slots, minibatches) of the task's default PPO training on the GPU sweep"""
    t = task_section(task)
    slots = (t.get("env") or {}).get("slots")
    return (slots, (t.get("ppo") or {}).get("minibatches", 4)) if slots else (16384, 16)


def names_yaml(config, want):
    """whether a run's task YAML path names `want` (a path from the source root, where this runs):
    the same path once normalised ('./', 'a/../'), or an absolute path ending in it (a run started
    from another checkout, or with the path spelled out)"""
    c, w = os.path.normpath(config), os.path.normpath(want)
    return c == w or (os.path.isabs(c) and c.endswith(os.sep + w))


def is_default(run_dir, task, version):
    cfg = yaml.safe_load(open(os.path.join(run_dir, "config.yaml")))
    info = json.load(open(os.path.join(run_dir, "run.json")))
    if int(cfg.get("seed", -1)) != 0:
        return False
    if (cfg["env"]["slots"], cfg["ppo"]["minibatches"]) != default_training(task):
        return False
    section = task_section(task)
    # the section's other PPO settings (minibatches: the sweep's, above)
    for key, value in (section.get("ppo") or {}).items():
        if key != "minibatches" and cfg["ppo"].get(key) != value:
            return False
    config = cfg["env"].get("task_config") or ""
    aid = (section.get("env") or {}).get("task_config") or ""
    if config or aid:
        return bool(config) and any(names_yaml(config, w) for w in (aid, EQUIVALENT.get(task)) if w)
    return info.get("task_version") == f"{task}-v{version}"


def milestone(run_dir, run, task):
    rows = rows_of(os.path.join(run_dir, "metrics.csv"))
    if task in GOAL_FROM_ORIGINAL:
        goal, target, f = "original_final", ORIGINAL_PPO_FINAL[task], comparable
    else:
        goal, target, f = "success", SUCCESS_GOAL, lambda r: num(r, "success")
    out = {"goal": goal, "target": target, "trained": run["slot_steps"],
           "run": run_dir, "commit": run["commit"]}
    for i in range(len(rows)):
        v = recent(rows, i, f)
        if v is not None and v >= target:
            return {**out, "by": "training", "slot_steps": int(float(rows[i]["steps"])),
                    "wall_s": round(float(rows[i]["wall_s"]), 1)}
    ev = run.get("eval") or {}
    met = ev and (ev["return"] >= target if goal == "original_final" else ev["success"] >= target)
    if met:
        return {**out, "by": "evaluation", "slot_steps": run["slot_steps"],
                "wall_s": round(run["wall_s"], 1)}
    return {**out, "by": "not_reached", "slot_steps": None, "wall_s": None}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--bidex", default="build/apps/bidex")
    ap.add_argument("--out", default="configs/registry/time_to_goal.yaml")
    a = ap.parse_args()
    best = {}  # task -> (run dir, run)
    info = {}  # task -> `bidex info --json`
    for d in a.dirs:
        sweep = json.load(open(os.path.join(d, "sweep.json")))
        for run in sweep["runs"]:
            task, rd = run["task"], os.path.join(d, run["run"])
            if is_suite(task) or not os.path.exists(os.path.join(rd, "config.yaml")):
                continue
            if task not in info:
                info[task] = json.loads(subprocess.run([a.bidex, "info", "--task", task, "--json"],
                                                       check=True, capture_output=True,
                                                       text=True).stdout)
            if not is_default(rd, task, info[task]["version"]):
                continue
            run = {**run, "commit": sweep["commit"]}
            if task not in best or run["slot_steps"] > best[task][1]["slot_steps"]:
                best[task] = (rd, run)
    values = {t: milestone(rd, run, t) for t, (rd, run) in sorted(best.items())}
    head = ("# Generated by bench/sweep_time_to_goal.py from the PPO sweep's folders; do not edit.\n"
            "# Each task's time to its goal at its default settings (the script's docstring says\n"
            "# how); the registry loads it and `bidex registry report age` draws it against age.\n"
            f"# Command: bench/sweep_time_to_goal.py {' '.join(a.dirs)}\n")
    doc = {"source": "bidex PPO sweep (issue 36), bench/results/sweep-h100x4/README.md",
           "success_goal": SUCCESS_GOAL, "values": values}
    with atomic_open(a.out) as fh:
        fh.write(head)
        yaml.safe_dump(doc, fh, sort_keys=False, width=100)
    for t, v in values.items():
        s = "-" if v["slot_steps"] is None else f"{v['slot_steps'] / 1e6:.1f}M"
        print(f"{t:<22} {v['goal']:<15} {s:>7} {v['by']:<12} trained {v['trained'] / 1e6:.1f}M  {v['run']}")
    missing = sorted(set(info) - set(values))
    if missing:
        print("no default run:", ", ".join(missing))
    # does a skill that comes later to infants take PPO longer? Spearman's rank correlation of
    # the age (the middle of its range) and the slot-steps (a task not reached ranks last)
    ages = {t: info[t]["age"] for t in values}
    xs = [0.5 * (ages[t]["min_months"] + ages[t]["max_months"]) for t in values]
    ys = [v["slot_steps"] if v["slot_steps"] is not None else float("inf") for v in values.values()]
    rho = spearman(xs, ys)
    print(f"Spearman's rank correlation of human age and slot-steps to the goal over "
          f"{len(xs)} tasks: " + ("undefined (it needs two tasks or more, of different ages and "
                                   "times)" if rho is None else f"{rho:.3f}"))


def ranks(v):
    """1-based ranks, ties at their mean rank"""
    order = sorted(range(len(v)), key=lambda i: v[i])
    r = [0.0] * len(v)
    i = 0
    while i < len(order):
        j = i
        while j + 1 < len(order) and v[order[j + 1]] == v[order[i]]:
            j += 1
        for k in range(i, j + 1):
            r[order[k]] = (i + j) / 2 + 1
        i = j + 1
    return r


def spearman(x, y):
    """Spearman's rank correlation; None where it is undefined (fewer than two values, or every
    value of one side tied)"""
    if len(x) < 2:
        return None
    rx, ry = ranks(x), ranks(y)
    mx, my = sum(rx) / len(rx), sum(ry) / len(ry)
    cov = sum((a - mx) * (b - my) for a, b in zip(rx, ry))
    var = sum((a - mx) ** 2 for a in rx) * sum((b - my) ** 2 for b in ry)
    return cov / var ** 0.5 if var > 0 else None


if __name__ == "__main__":
    main()
