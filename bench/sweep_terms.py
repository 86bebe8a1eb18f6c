#!/usr/bin/env python3
"""Each reward term of sweep runs, per step, over their last slot-steps: the episode-weighted mean
of each term's episode sum (bench/sweep_collect.py's window()) divided by the same mean of the
episode length; also the return, the length and the success rate. What the sweep README's "what
the trials show" quotes. With --every M, instead: the return, length and success rate over each
successive window of M million slot-steps from the start (how a run rose).
Usage: bench/sweep_terms.py RUN_DIR [RUN_DIR...] [--last MILLIONS (default 5)] [--every MILLIONS]"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sweep_collect import num, rows_of, window  # noqa: E402  (the one definition of each)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", metavar="RUN_DIR")
    ap.add_argument("--last", type=float, default=5.0, help="slot-steps in millions")
    ap.add_argument("--every", type=float, help="windows of this many million slot-steps from the start")
    a = ap.parse_args()
    if a.every is not None and not a.every > 0:
        ap.error(f"--every: expected a positive number of million slot-steps, got {a.every:g}")
    for d in a.runs:
        rows = rows_of(os.path.join(d, "metrics.csv"))
        if not rows:
            sys.exit(f"sweep_terms: {d}/metrics.csv: no updates with ended episodes")
        hi = float(rows[-1]["steps"])
        if a.every:
            print(f"{d}: the episodes that ended in each window of {a.every:g}M slot-steps")
            step, lo = a.every * 1e6, 0.0
            while lo < hi:
                mean = lambda key: window(rows, lo, lo + step, lambda r: num(r, key))
                if mean("length") is not None:
                    print(f"  ({lo / 1e6:.0f}M, {(lo + step) / 1e6:.0f}M]  return {mean('return'):10.3f}"
                          f"  length {mean('length'):6.1f}  success {mean('success'):.4f}")
                lo += step
            continue
        lo = hi - a.last * 1e6
        mean = lambda key: window(rows, lo, hi, lambda r: num(r, key))
        length = mean("length")
        print(f"{d}: the episodes that ended in ({lo / 1e6:.1f}M, {hi / 1e6:.1f}M] slot-steps")
        print(f"  return {mean('return'):.3f}  length {length:.1f}  success {mean('success'):.4f}")
        for key in rows[0]:
            if key.startswith("term_"):
                ep = mean(key)
                print(f"  {key[5:]:<16} {ep:12.4f} an episode {ep / length:10.4f} a step")


if __name__ == "__main__":
    main()
