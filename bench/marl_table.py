#!/usr/bin/env python3
"""The multi-agent GPU runs (bench/gpu_marl_run.sh) beside the original's and HARL's figures:
OUTDIR/table.md and .json, and one curve per task (OUTDIR/curve-TASK.svg).
Usage: bench/marl_table.py OUTDIR"""
import json, os, subprocess, sys

out = sys.argv[1]
here = os.path.dirname(os.path.abspath(__file__))
# final mean training returns at about 100M steps, means of 10 seeds (the original's
# dataset/<task>/<algo>/test_rew_10seeds.csv), and HARL's HAPPO on pen read off its plot
ORIGINAL = {
    "hand_over": {"ppo": 30.8, "mappo": 28.1, "happo": 27.2},
    "catch_over2underarm": {"ppo": 28.4, "mappo": 16.6, "happo": 17.6},
    "pen": {},
}
HARL = {"pen": ("HARL HAPPO at 50M (read off its plot)", 185.0)}
# the original's PPO on hand_over within our runs' range (means of its 10 seeds)
ORIGINAL_PPO_POINTS = {"hand_over": "2e6:3.6,10e6:17.6"}

rows = []
for name in sorted(os.listdir(out)):
    # result.json: the committed form of the last call's time_to_target.json
    t = next((os.path.join(out, name, f) for f in ("result.json", "time_to_target.json")
              if os.path.isfile(os.path.join(out, name, f))), None)
    if t is None:
        continue
    d = json.load(open(t))
    task, algo, *agents = name.split("-")
    rows.append({"run": name, "task": task, "algo": algo,
                 "agents": agents[0] if agents else "hand",
                 "slot_steps": d["slot_steps"], "wall_s": d["wall_s"],
                 "return_last_10_updates": d["return_last_10_updates"],
                 "train_fps_median": d["train_fps_median"], "machine": d["machine"],
                 "commit": d["commit"], "date": d["date"],
                 "original_final": None if agents else ORIGINAL.get(task, {}).get(algo),
                 "commands": d["commands"]})

lines = ["| task | algorithm | agents | slot-steps | wall (s) | return (last 10 updates) | "
         "the original's final (100M) |", "|---|---|---|---|---|---|---|"]
for r in rows:
    orig = r["original_final"]
    lines.append(f"| {r['task']} | {r['algo'].upper()} | {r['agents']} | "
                 f"{r['slot_steps'] / 1e6:.1f}M | {r['wall_s']:.0f} | "
                 f"{r['return_last_10_updates']:.2f} | {'' if orig is None else orig} |")
open(os.path.join(out, "table.md"), "w").write("\n".join(lines) + "\n")
json.dump(rows, open(os.path.join(out, "table.json"), "w"), indent=2)
print("\n".join(lines))

for task in sorted({r["task"] for r in rows}):
    args = [sys.executable, os.path.join(here, "curve_vs_original.py"),
            os.path.join(out, f"curve-{task}.svg"), f"{task}: multi-agent runs on one H100"]
    for r in rows:
        if r["task"] == task:
            args += ["--run", f"{r['algo'].upper()} ({r['agents']})="
                     + os.path.join(out, r["run"], "metrics.csv")]
    for algo, v in ORIGINAL.get(task, {}).items():
        args += ["--line", f"the original's {algo.upper()} at 100M={v}"]
    if task in ORIGINAL_PPO_POINTS:
        args += ["--orig", f"the original's PPO={ORIGINAL_PPO_POINTS[task]}"]
    if task in HARL:
        args += ["--line", f"{HARL[task][0]}={HARL[task][1]}"]
    subprocess.run(args, check=True)
