#!/usr/bin/env python3
"""Each reward term of sweep runs, per step, over their last slot-steps: the episode-weighted mean
of each term's episode sum (bench/sweep_collect.py's window()) divided by the same mean of the
episode length; also the return, the length and the success rate. What the sweep README's "what
the trials show" quotes.
Usage: bench/sweep_terms.py RUN_DIR [RUN_DIR...] [--last MILLIONS (default 5)]"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sweep_collect import num, rows_of, window  # noqa: E402  (the one definition of each)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", metavar="RUN_DIR")
    ap.add_argument("--last", type=float, default=5.0, help="slot-steps in millions")
    a = ap.parse_args()
    for d in a.runs:
        rows = rows_of(os.path.join(d, "metrics.csv"))
        if not rows:
            sys.exit(f"sweep_terms: {d}/metrics.csv: no updates with ended episodes")
        hi = float(rows[-1]["steps"])
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
