#!/usr/bin/env python3
"""The registry's tasks by human age with their reference scores, and each finished run's
normalised score per task, read with Python's own sqlite3 (registry/README.md has the schema).

    python3 examples/registry_scores.py [REGISTRY]   (default: $BIDEX_REGISTRY, else
                                                      runs/registry.sqlite)

normalised score = (return - random) / (ground truth - random): 0 is a random policy, 1 the
ground truth; empty where a reference is missing.
"""
import os
import sqlite3
import sys


def main(path):
    if not os.path.isfile(path):
        sys.exit(f"registry_scores: {path}: no registry file there (bidex registry list "
                 f"--registry {path} makes one)")
    db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)  # read only: never changes it
    refs = {(t, k): v for t, k, v in db.execute("SELECT task, kind, value FROM reference_scores")}

    def normalised(task, ret):
        r, g = refs.get((task, "random")), refs.get((task, "ground_truth"))
        return None if r is None or g is None or g == r else (ret - r) / (g - r)

    print(f"{'task':<22} {'age':>6} {'difficulty':<10} {'random':>10} {'ground truth':>12}")
    for tid, age, diff in db.execute(
            "SELECT id, age_text, difficulty FROM tasks WHERE origin != 'variant' "
            "ORDER BY age_min, age_max, id"):  # the paper's tasks, as bidex registry list
        r, g = refs.get((tid, "random")), refs.get((tid, "ground_truth"))
        cell = lambda v: "-" if v is None else f"{v:.4g}"
        print(f"{tid:<22} {age:>6} {diff:<10} {cell(r):>10} {cell(g):>12}")
    rows = db.execute("""SELECT r.id, r.algo, s.task, s.label, s.mean_return, s.success
                         FROM runs r JOIN run_scores s ON s.run = r.id
                         WHERE r.status = 'finished' ORDER BY r.id, s.position""").fetchall()
    print(f"\n{len(rows)} scores of finished runs")
    for run, algo, task, label, ret, success in rows:
        n = normalised(task, ret)
        print(f"run {run:<4} {algo:<8} {label:<22} return {ret:10.3f}  normalised "
              f"{'-' if n is None else f'{n:.3f}'}  success {'-' if success is None else f'{success:.2f}'}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else
         os.environ.get("BIDEX_REGISTRY") or "runs/registry.sqlite")
