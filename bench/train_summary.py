#!/usr/bin/env python3
"""Summarises one bench/train_run.sh result folder (OUT/<task>/ with sim_only.json, eval.json and
the run's metrics.csv, run.json, config.yaml) into one JSON: machine, date, commit, commands,
training steps and wall time, returns, and training vs simulation-only throughput.
Usage: bench/train_summary.py RESULT_DIR RUN_DIR OUT.json"""
import csv, json, statistics, sys

res, run, out = sys.argv[1:4]
sim = json.load(open(f"{res}/sim_only.json"))
ev = json.load(open(f"{res}/eval.json"))
rj = json.load(open(f"{run}/run.json"))
rows = list(csv.DictReader(open(f"{run}/metrics.csv")))
num = lambda r, k: float(r[k]) if r[k] != "" else None
steady = rows[5:] or rows  # the first updates include warm-up (allocations, CUDA kernels)
fps = statistics.median(num(r, "fps") for r in steady)
sim_in_run = statistics.median(num(r, "sim_fps") for r in steady)
sim_only = sim["results"][0]["slot_steps_per_s"]
finished = [r for r in rows if r["return"] != ""]
last = finished[-10:]
summary = {
    "what": "PPO on one task: simulation-only throughput, then a timed training run, then an evaluation of the mean action",
    "task": rj["task"], "task_version": rj["task_version"],
    "machine": sim["machine"],
    "commands": [sim["command"]] + [s["command"] for s in rj["sessions"]] + [ev["command"]],
    "device": rj["sessions"][-1]["device"], "threads": rj["sessions"][-1]["threads"],
    "slots": sim["results"][0]["slots"],
    "updates": int(num(rows[-1], "update")), "slot_steps": int(num(rows[-1], "steps")),
    "wall_s": num(rows[-1], "wall_s"),
    "train_fps_median": fps,
    "sim_fps_inside_training_median": sim_in_run,
    "sim_only_fps": sim_only,
    "train_vs_sim_only": fps / sim_only,
    "train_vs_sim_inside_training": fps / sim_in_run,
    "return_last_10_updates": statistics.mean(num(r, "return") for r in last) if last else None,
    "success_last_10_updates": statistics.mean(num(r, "success") for r in last) if last else None,
    "eval": {k: ev[k] for k in ("episodes", "mean_return", "std_return", "success_rate", "mean_length", "faults", "update")},
    "curve": [{"steps": int(num(r, "steps")), "return": num(r, "return"), "success": num(r, "success")}
              for r in finished[:: max(1, len(finished) // 25)]],
}
json.dump(summary, open(out, "w"), indent=2)
print(json.dumps({k: summary[k] for k in ("task", "slot_steps", "train_fps_median", "sim_only_fps", "train_vs_sim_only", "return_last_10_updates")}, indent=1))
