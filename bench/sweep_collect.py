#!/usr/bin/env python3
"""Summarises the PPO sweep's runs (bench/sweep_run.sh collect): per run OUTDIR/RUN/time_to_target.json
and one OUTDIR/sweep.json.
Usage: bench/sweep_collect.py OUTDIR MACHINE COMMIT RUN...   (RUN: TASK[/sSEED][/mMILLIONS][/cNAME][/oNAME], bench/sweep_run.sh)
       bench/sweep_collect.py --rising METRICS_CSV   (exit 0: the run still rises)
       bench/sweep_collect.py --refresh OUTDIR   (OUTDIR/sweep.json summarised again from its runs'
           committed files by today's rules, keeping its machine, commit and date)"""
import datetime, json, os, sys

from atomic_io import write_json  # bench/atomic_io.py, beside this script
from metrics_io import metrics_exists, read_metrics  # plain or .xz

# The original's published PPO finals: the last row of its 10-seed learning curves, about 1e8
# environment steps (mean over 10 seeds), for the nine tasks it published curves for.
ORIGINAL_PPO_FINAL = {
    "hand_over": 30.8, "catch_underarm": 17.8, "catch_over2underarm": 28.4,
    "catch_abreast": 43.4, "two_catch_underarm": 14.1, "door_open_inward": 467.0,
    "door_open_outward": 580.0, "door_close_inward": 295.0, "door_close_outward": 1038.0,
}


def is_suite(task):
    """a suite's multi-task or meta run (configs/suites/TASK.yaml: MT4, ML20, ...), which a sweep
    folder may hold beside single tasks (bench/suite_train_table.py tables those)"""
    return os.path.exists(os.path.join("configs", "suites", task + ".yaml"))


def load(path):
    return json.load(open(path)) if os.path.exists(path) else None


def num(r, key):
    v = r.get(key, "")
    return float(v) if v not in ("", None) else None


def weighted(pairs):
    """The weighted mean of (value, weight) pairs, skipping those without a value (None when no
    weight is left)."""
    pairs = [(x, w) for x, w in pairs if x is not None and w > 0]
    total = sum(w for _, w in pairs)
    return sum(x * w for x, w in pairs) / total if total else None


def episodes(r):
    return float(r.get("episodes") or 0)


def comparable(r):
    """The training return without bidex's goal bonus: the original's bonus never fired
    (hand_over) or does not exist (the other tasks with a published curve)."""
    ret = num(r, "return")
    bonus = num(r, "term_goal_bonus") or 0.0
    return None if ret is None else ret - bonus


def window(rows, lo, hi, f):
    """The mean of f over the episodes that ended in (lo, hi] slot-steps: each update's mean
    weighted by its episodes. Tasks whose worlds end their episodes together (fixed lengths, no
    reset noise) have one update with thousands of episodes and many with a few; a plain mean
    over updates would count each of those few the same."""
    return weighted((f(r), episodes(r)) for r in rows if lo < float(r["steps"]) <= hi)


RECENT_EPISODES = 100  # the original's logged return: the mean of its last 100 episodes


def recent(rows, i, f):
    """The mean of f over the last RECENT_EPISODES episodes ended by update i (whole updates,
    newest first, until they hold that many), as the original's learning curves log it."""
    pairs, n = [], 0.0
    for r in reversed(rows[:i + 1]):
        pairs.append((f(r), episodes(r)))
        n += episodes(r)
        if n >= RECENT_EPISODES:
            break
    return weighted(pairs) if n >= RECENT_EPISODES else None


def updates_of(path):
    """Every update of a metrics.csv or its .xz (an empty list for a missing file)."""
    return read_metrics(path) if metrics_exists(path) else []


def ended(updates):
    """The updates that ended episodes."""
    return [r for r in updates if r["return"] != ""]


def rows_of(path):
    """The updates of a metrics.csv that ended episodes (an empty list for a missing file)."""
    return ended(updates_of(path))


def rising(rows):
    """Whether the mean training return (without goal bonus) or success of the last 10M
    slot-steps beats that of the 10M before by more than 2%."""
    if not rows:
        return False
    end = float(rows[-1]["steps"])
    last, prev = (window(rows, end - 1e7, end, comparable),
                  window(rows, end - 2e7, end - 1e7, comparable))
    slast, sprev = (window(rows, end - 1e7, end, lambda r: num(r, "success")),
                    window(rows, end - 2e7, end - 1e7, lambda r: num(r, "success")))
    return (last is not None and prev is not None and last - prev > 0.02 * max(abs(prev), 1)) \
        or (slast is not None and sprev is not None and slast - sprev > 0.02)


def first_last(updates, key, n=10, skip=5):
    """The mean of a metrics column over the n updates after the first `skip` (kernels compile
    and the first episodes end there) and over the last n: how a rate or the physics' load
    moved over the run; None where the column is missing (a log from before it)."""
    vals = [num(r, key) for r in updates]
    head = [v for v in vals[skip:skip + n] if v is not None]
    tail = [v for v in vals[-n:] if v is not None]
    return {"first": sum(head) / len(head) if head else None,
            "last": sum(tail) / len(tail) if tail else None}


def eval_row(ev):
    """the fields of a `bidex eval --json` file the table shows, or None"""
    return None if ev is None else {
        "update": ev.get("update"), "episodes": ev["episodes"],
        "return": ev["mean_return"], "std": ev["std_return"],
        "success": ev["success_rate"], "length": ev["mean_length"], "faults": ev["faults"]}


def summarise(outdir, spec):
    task, *parts = spec.split("/")
    seed = next((p[1:] for p in parts if p.startswith("s")), "0")
    config = next((p[1:] for p in parts if p.startswith("c")), None)
    overrides = [p[1:] for p in parts if p.startswith("o")]  # every part oNAME, in order
    name = spec.replace("/", "-")
    d = os.path.join(outdir, name)
    updates = updates_of(f"{d}/metrics.csv")
    rows = ended(updates)
    # how far it trained: the last update, whether or not episodes ended in it (fixed-length
    # episodes end together, so the last update with a return can be a few updates earlier)
    trained = updates[-1] if updates else None
    summary, ev = load(f"{d}/summary.json"), load(f"{d}/eval.json")
    ev_default = load(f"{d}/eval-default.json")  # the part e: under the task's own YAML
    # the parts eNAME: under bench/sweep/NAME.yaml
    ev_named = {p[1:]: eval_row(load(f"{d}/eval-{p[1:]}.json")) for p in parts
                if p.startswith("e") and len(p) > 1}
    end = float(rows[-1]["steps"]) if rows else 0.0
    target = ORIGINAL_PPO_FINAL.get(task)
    reached = [recent(rows, i, comparable) for i in range(len(rows))] if target else []
    first = next((i for i, v in enumerate(reached) if v is not None and v >= target), None)
    hit = None if first is None else rows[first]
    fps = sorted(float(r["fps"]) for r in rows[3:] or rows)
    commands = open(f"{d}/commands.txt").read().splitlines() if os.path.exists(f"{d}/commands.txt") else []
    t = {
        "task": task, "seed": int(seed), "run": name,
        "task_config": None if config is None else f"bench/sweep/{config}.yaml",
        "overrides": [f"bench/sweep/{o}.overrides" for o in overrides] or None,
        "commands": commands,
        "slot_steps": int(float(trained["steps"])) if trained else 0,
        "wall_s": float(trained["wall_s"]) if trained else 0.0,
        "finished": bool(summary and summary.get("finished")),
        "train_fps_median": fps[len(fps) // 2] if fps else None,
        "train_return_last_10M": window(rows, end - 1e7, end, lambda r: num(r, "return")),
        "train_return_no_bonus_last_10M": window(rows, end - 1e7, end, comparable),
        "train_success_last_10M": window(rows, end - 1e7, end, lambda r: num(r, "success")),
        "still_rising": rising(rows),
        "original_ppo_final": target,
        "reached_original": hit is not None,
        "reached_at": None if hit is None else {
            "wall_s": float(hit["wall_s"]), "slot_steps": int(float(hit["steps"])),
            "return_no_bonus": reached[first]},
        "eval": eval_row(ev),
        "eval_default_yaml": eval_row(ev_default),
        "eval_under": ev_named,
        "gpu_rows": summary.get("gpu_rows") if summary else None,
        # the simulation's rate and its load (constraint rows and solver iterations per
        # slot-step) early and late in the run: whether a falling sim_fps came with more contacts
        "physics_load": {k: first_last(updates, k) for k in ("sim_fps", "efc_rows", "solver_iters")},
    }
    write_json(f"{d}/time_to_target.json",
               {k: t[k] for k in ("task", "seed", "original_ppo_final", "reached_original",
                                  "reached_at", "slot_steps", "wall_s", "train_fps_median")},
               indent=2)
    return t


def main():
    if len(sys.argv) == 3 and sys.argv[1] == "--rising":  # bench/sweep_run.sh's extensions
        sys.exit(0 if rising(rows_of(sys.argv[2])) else 1)
    if len(sys.argv) == 3 and sys.argv[1] == "--refresh":
        outdir = sys.argv[2]
        old = load(os.path.join(outdir, "sweep.json"))
        if old is None:
            sys.exit(f"{outdir}/sweep.json: no such file (--refresh re-summarises a collected sweep)")
        specs = open(os.path.join(outdir, "lanes")).read().split()
        write(outdir, old["machine"], old["commit"], old["date"], specs,
              datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"))
        return
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    outdir, machine, commit, specs = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
    write(outdir, machine, commit,
          datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"), specs)


def write(outdir, machine, commit, date, specs, refreshed=None):
    """OUTDIR/sweep.json (atomically) and a line per run on stdout"""
    out = {
        "what": "PPO at the paper's settings (16,384 slots, 16 minibatches, unless the task's "
                "section of configs/train/ppo.yaml sets its own slots) on every task on the "
                "GPU path; each final policy's mean action evaluated over 256 episodes on the CPU "
                "path; training returns and success as means over episodes; the wall time and "
                "slot-steps at which the mean training return (without bidex's goal bonus) of the "
                "last 100 episodes first reached the original's published PPO final",
        "machine": machine, "commit": commit, "date": date,
        **({"summarised_again": refreshed} if refreshed else {}),
        "runs": [summarise(outdir, s) for s in specs],
    }
    write_json(os.path.join(outdir, "sweep.json"), out, indent=2)
    for t in out["runs"]:
        e = t["eval"] or {}
        print(f"{t['run']:<24} {t['slot_steps'] / 1e6:6.1f}M {t['wall_s']:6.0f}s "
              f"train {t['train_return_last_10M'] or float('nan'):9.2f} "
              f"eval {e.get('return', float('nan')):9.2f} success {e.get('success', float('nan')):.2f} "
              f"len {e.get('length', float('nan')):.0f} faults {e.get('faults')} "
              f"{'rising' if t['still_rising'] else ''} "
              f"{'reached ' + str(t['reached_at']) if t['reached_original'] else ''}")


if __name__ == "__main__":
    main()
