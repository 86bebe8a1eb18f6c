#!/usr/bin/env python3
"""A run's metrics.csv as the bench scripts read it: plain, as the trainer writes it, or
compressed as metrics.csv.xz, as bench/results keeps it (xz's -9 makes the CSV about a third of
its size, and the lease's bundle parts are larger for every megabyte the tracked tree sheds:
scripts/offline-build.sh sizes them from the tree).

    read_metrics(path)    the rows of PATH (a name ending in metrics.csv), or of PATH.xz when PATH
                          is absent, as csv.DictReader gives them; FileNotFoundError naming both if
                          neither is there (PATH may also name the .xz file itself)
    metrics_exists(path)  whether PATH or PATH.xz is there

    bench/metrics_io.py compress DIR...
        every metrics.csv under each DIR becomes metrics.csv.xz (written atomically, read back and
        compared before the plain file is removed); prints what it did
"""
import csv
import lzma
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from atomic_io import replacing  # noqa: E402


def read_metrics(path):
    if path.endswith(".xz"):  # the compressed file named itself
        path = path[:-3]
    if os.path.exists(path):
        f = open(path, newline="")
    elif os.path.exists(path + ".xz"):
        f = lzma.open(path + ".xz", "rt", newline="")
    else:
        raise FileNotFoundError(f"{path}: no such file, nor {path}.xz")
    with f:
        return list(csv.DictReader(f))


def metrics_exists(path):
    return os.path.exists(path) or os.path.exists(path + ".xz")


def compress(path):
    """PATH (a plain metrics.csv) to PATH.xz; returns (bytes before, bytes after)"""
    with open(path, "rb") as f:
        data = f.read()
    with replacing(path + ".xz") as tmp:
        with lzma.open(tmp, "wb", preset=9) as z:
            z.write(data)
    with lzma.open(path + ".xz", "rb") as z:
        if z.read() != data:
            os.remove(path + ".xz")
            sys.exit(f"metrics_io: {path}.xz does not read back as {path}; the plain file is kept")
    os.remove(path)
    return len(data), os.path.getsize(path + ".xz")


def main(argv):
    if len(argv) < 2 or argv[0] != "compress":
        print(__doc__.strip())
        sys.exit(0 if argv[:1] in (["-h"], ["--help"]) else 2)
    before = after = n = 0
    for d in argv[1:]:
        if not os.path.isdir(d):
            sys.exit(f"metrics_io: {d}: expected a folder")
        for root, _, files in sorted(os.walk(d)):
            if "metrics.csv" in files:
                b, a = compress(os.path.join(root, "metrics.csv"))
                before, after, n = before + b, after + a, n + 1
    print(f"metrics_io: {n} metrics.csv compressed, {before:,} bytes to {after:,}")


if __name__ == "__main__":
    main(sys.argv[1:])
