#!/usr/bin/env python3
"""The offline table from a registry: every finished offline run's final return (its last
policy's evaluation episodes), normalised with its dataset's references (random 0, online PPO 100;
a replay dataset takes its task's), averaged over seeds per task, dataset quality and algorithm,
beside the original's published scores. Writes OUT/table.md and OUT/table.json.

usage: offline_table.py REGISTRY OUT COMMIT
"""
import datetime
import json
import platform
import sqlite3
import statistics
import subprocess
import sys

# The original's normalised scores (its project page; online PPO 100), for comparison.
PAPER = {
    ("hand_over", "random"): {"bc": 0.7, "bcq": 1.0, "td3bc": 0.9, "iql": 0.7},
    ("hand_over", "replay"): {"bc": 17.5, "bcq": 61.6, "td3bc": 70.1, "iql": 43.1},
    ("hand_over", "medium"): {"bc": 61.6, "bcq": 66.1, "td3bc": 65.8, "iql": 57.4},
    ("hand_over", "medium-expert"): {"bc": 63.3, "bcq": 81.7, "td3bc": 84.9, "iql": 67.2},
    ("door_open_outward", "random"): {"bc": 2.1, "bcq": 23.8, "td3bc": 34.9, "iql": 3.8},
    ("door_open_outward", "replay"): {"bc": 36.9, "bcq": 48.8, "td3bc": 60.5, "iql": 31.7},
    ("door_open_outward", "medium"): {"bc": 63.9, "bcq": 60.1, "td3bc": 66.3, "iql": 56.6},
    ("door_open_outward", "medium-expert"): {"bc": 69.0, "bcq": 73.7, "td3bc": 71.9,
                                             "iql": 53.8},
}
QUALITIES = ["random", "replay", "medium", "medium-expert", "expert"]
ALGOS = ["bc", "bcq", "td3bc", "iql"]


def main(reg_path, out, commit):
    db = sqlite3.connect(reg_path)
    datasets = {}
    for row in db.execute("SELECT checksum, dataset_id, task, quality, total_steps, "
                          "total_episodes, ref_min, ref_max, added FROM datasets"):
        datasets[row[0]] = dict(zip(["checksum", "id", "task", "quality", "steps", "episodes",
                                     "ref_min", "ref_max", "added"], row))

    def refs(d):
        if d["ref_min"] is not None and d["ref_max"] is not None:
            return d["ref_min"], d["ref_max"]
        same = [o for o in datasets.values() if o["task"] == d["task"] and
                o["ref_min"] is not None and o["ref_max"] is not None]
        if not same:
            return None
        o = max(same, key=lambda o: o["added"])
        return o["ref_min"], o["ref_max"]

    cells = {}
    short = set()  # cells with a run that stopped before its gradient steps (time limit)
    runs = []
    for rid, algo, ck, ret, steps, status, seed in db.execute(
            "SELECT id, algo, dataset, final_return, steps, status, seed FROM runs "
            "WHERE dataset != ''"):
        d = datasets.get(ck)
        if d is None or ret is None:
            continue
        r = refs(d)
        norm = None if r is None or r[1] == r[0] else 100 * (ret - r[0]) / (r[1] - r[0])
        runs.append({"run": rid, "algo": algo, "task": d["task"], "quality": d["quality"],
                     "dataset": ck, "seed": seed, "gradient_steps": steps, "status": status,
                     "final_return": ret, "normalised": norm})
        if norm is not None:
            cells.setdefault((d["task"], d["quality"], algo), []).append(norm)
            if status != "finished":
                short.add((d["task"], d["quality"], algo))
    tasks = sorted({k[0] for k in cells})
    lines = ["| task | dataset | " + " | ".join(a.upper().replace("TD3BC", "TD3+BC")
                                                 for a in ALGOS) + " |",
             "|---|---|" + "---|" * len(ALGOS)]
    table = []
    for t in tasks:
        for q in QUALITIES:
            if not any((t, q, a) in cells for a in ALGOS):
                continue
            row = []
            for a in ALGOS:
                v = cells.get((t, q, a))
                paper = PAPER.get((t, q), {}).get(a)
                mean = statistics.mean(v) if v else None
                table.append({"task": t, "quality": q, "algo": a, "normalised_mean": mean,
                              "runs": len(v or []), "stopped_short": (t, q, a) in short,
                              "original": paper})
                text = "-" if mean is None else f"{mean:.1f}"
                if v and len(v) > 1:
                    text += f" ± {statistics.stdev(v):.1f}"
                if (t, q, a) in short:
                    text += "*"
                row.append(text + (f" ({paper})" if paper is not None else ""))
            lines.append(f"| {t} | {q} | " + " | ".join(row) + " |")
    try:
        machine = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"],
                                 capture_output=True, text=True).stdout.strip()
    except FileNotFoundError:  # a machine without the NVIDIA driver
        machine = platform.node()
    now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    md = ["Normalised score (random 0, online PPO 100) of each offline algorithm's final policy, "
          "in brackets the original's.", "", *lines, ""]
    if short:
        md += ["\\* a run of this cell stopped at its time limit before its gradient steps "
               "(`gradient_steps` in table.json).", ""]
    open(f"{out}/table.md", "w").write("\n".join(md))
    json.dump({"what": "offline RL: normalised scores per task, dataset and algorithm",
               "machine": machine, "date": now, "commit": commit,
               "datasets": list(datasets.values()), "table": table, "runs": runs},
              open(f"{out}/table.json", "w"), indent=2)
    print("\n".join(md))


if __name__ == "__main__":
    main(*sys.argv[1:4])
