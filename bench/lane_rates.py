#!/usr/bin/env python3
"""Training rates of a lease's runs, in windows of each run's own wall time.

    bench/lane_rates.py DIR RUN [RUN ...] [--window S] [--sum]

DIR is a sweep folder (`bench/sweep_run.sh collect`), RUN a run folder under it that holds the
trainer's metrics.csv (columns wall_s and steps). For each window [a, a + S] of wall_s (S = 100 s
by default) a run's rate is the slot-steps at its last update in the window less those at its
first, over their wall_s difference; 0 where the window holds fewer than two updates (the run had
ended). The row `whole` is each run's last slot-steps over its last wall_s. --sum adds a column
`all`, the sum of the runs' rates in each window (runs that shared a GPU). The header names the
machine, date, commit and command; the table below it depends on the committed files alone
(tests/cmake/sweep_figures_test.cmake regenerates it).
"""
import argparse
import datetime
import math
import os
import platform
import shlex
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from metrics_io import read_metrics  # noqa: E402  (plain or .xz)


def read_run(path):
    """[(wall_s, steps)] of metrics.csv at PATH, in file order; exits naming the file on bad input"""
    try:
        rows = read_metrics(path)
    except FileNotFoundError as e:
        sys.exit(f"lane_rates: {e}")
    except OSError as e:
        sys.exit(f"lane_rates: cannot read {path}: {e.strerror}")
    if not rows:
        sys.exit(f"lane_rates: {path}: expected a header and at least one update, found none")
    missing = [c for c in ("wall_s", "steps") if c not in rows[0]]
    if missing:
        sys.exit(f"lane_rates: {path}: expected columns wall_s and steps, missing {', '.join(missing)}")
    try:
        return [(float(r["wall_s"]), float(r["steps"])) for r in rows]
    except (TypeError, ValueError) as e:
        sys.exit(f"lane_rates: {path}: a wall_s or steps value is not a number ({e})")


def rate(points, a, b):
    """slot-steps/s between the first and the last update with a <= wall_s <= b; 0 for fewer than two"""
    s = [p for p in points if a <= p[0] <= b]
    if len(s) < 2 or s[-1][0] == s[0][0]:
        return 0.0
    return (s[-1][1] - s[0][1]) / (s[-1][0] - s[0][0])


def table(runs, window, add_sum):
    """the table's lines (no header comments): one per window, then `whole`"""
    end = max(v[-1][0] for v in runs.values())
    n = max(1, math.ceil(end / window))
    names = list(runs)
    width = max([10] + [len(r) for r in names])
    head = "window_s   " + "  ".join(f"{r:>{width}}" for r in names) + ("  all" if add_sum else "")
    lines = [head.rstrip()]
    for i in range(n):
        a, b = i * window, (i + 1) * window
        rs = [rate(runs[r], a, b) for r in names]
        cells = "  ".join(f"{x:{width},.0f}" for x in rs)
        lines.append(f"{a:5d}-{b:<5d}" + cells + (f"  {sum(rs):,.0f}" if add_sum else ""))
    whole = [v[-1][1] / v[-1][0] if v[-1][0] > 0 else 0.0 for v in runs.values()]
    lines.append("whole      " + "  ".join(f"{x:{width},.0f}" for x in whole))
    return lines


def provenance(argv):
    """the header's machine, date, commit and command lines"""
    here = os.path.dirname(os.path.abspath(__file__))
    try:
        commit = subprocess.run(["git", "-C", here, "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit = "unknown"
    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    return [f"# machine: {os.cpu_count()} cores, {platform.machine()} (reads committed files); "
            f"date: {date}; commit: {commit}",
            "# command: bench/lane_rates.py " + shlex.join(argv)]


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    p.add_argument("dir", help="the sweep folder")
    p.add_argument("runs", nargs="+", metavar="RUN", help="run folders under DIR, each with metrics.csv")
    p.add_argument("--window", type=int, default=100, help="window length in whole seconds (default 100)")
    p.add_argument("--sum", action="store_true", help="add the column `all`: the runs' rates summed")
    a = p.parse_args(argv)
    if a.window <= 0:
        p.error(f"--window: expected a positive number of seconds, got {a.window}")
    runs = {r: read_run(os.path.join(a.dir, r, "metrics.csv")) for r in a.runs}
    print(f"# Slot-steps/s of each run in {a.window} s windows of its own training wall time "
          "(bench/lane_rates.py says how), and over the whole run")
    print("\n".join(provenance(argv)))
    print("\n".join(table(runs, a.window, a.sum)))


if __name__ == "__main__":
    main(sys.argv[1:])
