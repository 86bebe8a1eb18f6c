#!/usr/bin/env python3
"""Where a GPU step's time goes, from a kernel trace (bench/kernel_trace.sh run): per control
step, the GPU's busy time against its span, the kernels side by side on other streams, each
stream's own busy time and the gaps between its kernels, and the kernels by name.

    python3 bench/kernel_trace.py TRACE --out DIR [--bench JSON | --labels A,B,...] [--compare]
        [--step-kernel random_fill] [--skip 5] [--gap 0.25] [--top 25] [--streams 20]
        [--long-stream 300]

Steps are cut at the kernels whose name holds --step-kernel (`bidex bench pack` and `bench warp`
draw each step's random actions with _random_fill before stepping): step i runs from the end of
its draw to the start of the next, and holds the kernels that start in it. A pause of --gap
seconds between draws ends a phase (a pack or task built anew); the first --skip steps of each
phase (the benches' warm-up) and its last (cut by no draw) are left out. --bench names the
phases from `bidex bench pack`'s JSON, in the order it measures them: the pack, the pack with one
backend per scene, then each task alone; --labels names them in order where there is no JSON
(a run that failed). --compare adds the phase labelled `packed` against the mean of the phases
whose label does not start with `packed` (the tasks alone), kernel name by kernel name.

Per step (the median over a phase's steps):
  span      first kernel start to last kernel end
  busy      time in which at least one kernel runs (the union of the kernels' intervals)
  kernel    the kernels' durations added up (over busy: how many run side by side on average)
  idle      span - busy: nothing runs while the step is in flight
  per stream: its kernels, their summed durations and the gaps between them (span - busy on
  that stream: launch latency and waits); and the long streams (--long-stream kernels a step or
  more: a MuJoCo Warp backend's captured step) against the short ones (graphs the device
  launches, such as the bodies of MuJoCo Warp's solver loop), each group's kernels, summed time
  and busy time
Kernel names are shortened: Warp's module hashes and _cuda_kernel_forward are cut, so that one
kernel of MuJoCo Warp compiled for several scenes reads as one name.

Writes DIR/kernel-trace.json and DIR/kernel-trace.txt.
"""
import argparse
import bisect
import json
import lzma
import os
import re
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from atomic_io import write_json, write_text  # noqa: E402


def parse():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("trace", help="the file bench/kernel_trace.sh run wrote (or it xz-compressed, "
                                 "named .xz)")
    p.add_argument("--out", required=True, help="folder for kernel-trace.{json,txt}")
    p.add_argument("--bench", help="bidex bench pack's JSON: names the phases")
    p.add_argument("--labels", help="the phases' names, comma-separated, in order")
    p.add_argument("--compare", action="store_true",
                   help="the phase `packed` against the mean of the tasks alone")
    p.add_argument("--step-kernel", default="random_fill",
                   help="text in the name of the kernel that starts each step")
    p.add_argument("--skip", type=int, default=5, help="warm-up steps left out of each phase")
    p.add_argument("--gap", type=float, default=0.25,
                   help="seconds between two draws that end a phase")
    p.add_argument("--top", type=int, default=25, help="kernel names listed per phase")
    p.add_argument("--long-stream", type=int, default=300,
                   help="kernels a step that make a stream long: a backend's captured step, "
                        "where the short ones are graphs the device launches (a loop's bodies)")
    p.add_argument("--streams", type=int, default=20,
                   help="streams listed per phase in the text (the JSON has them all)")
    return p.parse_args()


HASH = re.compile(r"_[0-9a-f]{7,}(?=_|$)")


def short(name):
    n = name.replace("_cuda_kernel_forward", "").replace("_cuda_kernel_backward", "_backward")
    return HASH.sub("", n)


def read_trace(path):
    """(kernels sorted by start as (start, end, stream, name_id, threads), names, dropped,
    unstamped)."""
    names, kernels, dropped, unstamped = {}, [], 0, 0
    try:
        f = lzma.open(path, "rt") if path.endswith(".xz") else open(path)
    except OSError as e:
        sys.exit(f"kernel_trace: cannot read {path}: {e.strerror}")
    lineno, line = 0, ""
    try:
        with f:
            for lineno, line in enumerate(f, 1):
                p = line.rstrip("\n").split("\t")
                if p[0] == "K":
                    k = (int(p[1]), int(p[2]), int(p[3]), int(p[7]), int(p[5]))
                    if k[0] > 0 and k[1] >= k[0]:
                        kernels.append(k)
                    else:  # CUPTI had no time for it (a program that failed, for one)
                        unstamped += 1
                elif p[0] == "N":
                    names[int(p[1])] = p[2]
                elif p[0] == "D":
                    dropped += int(p[1])
                elif p[0] not in ("C", "S"):
                    raise ValueError(f"record type {p[0]!r}")
    except (IndexError, ValueError) as e:
        sys.exit(f"kernel_trace: {path}:{lineno}: expected a K, N, C, S or D record "
                 f"(bench/kernel_trace.cc), got {line.strip()[:80]!r} ({e})")
    except (lzma.LZMAError, EOFError, OSError) as e:  # a damaged or cut .xz
        sys.exit(f"kernel_trace: {path}: cannot read past line {lineno}: {e}")
    if not kernels:
        sys.exit(f"kernel_trace: {path} holds no kernel records")
    missing = {k[3] for k in kernels} - names.keys()
    if missing:
        sys.exit(f"kernel_trace: {path}: kernel name ids {sorted(missing)[:5]} have no N record")
    kernels.sort()
    return kernels, names, dropped, unstamped


def union(intervals):
    """Total length covered by (start, end) intervals sorted by start."""
    total, cur_s, cur_e = 0, None, None
    for s, e in intervals:
        if cur_e is None or s > cur_e:
            if cur_e is not None:
                total += cur_e - cur_s
            cur_s, cur_e = s, e
        elif e > cur_e:
            cur_e = e
    if cur_e is not None:
        total += cur_e - cur_s
    return total


def phases(kernels, names, step_kernel, gap_ns):
    """Lists of draw kernels, one list per phase."""
    draws = [k for k in kernels if step_kernel in names[k[3]]]
    if not draws:
        sys.exit(f"kernel_trace: no kernel's name holds {step_kernel!r} (--step-kernel)")
    out = [[draws[0]]]
    for d in draws[1:]:
        if d[0] - out[-1][-1][0] > gap_ns:
            out.append([])
        out[-1].append(d)
    return out


def step_stats(ks, names, long_stream):
    """One step's measures from its kernels (sorted by start)."""
    span = max(k[1] for k in ks) - ks[0][0]
    busy = union([(k[0], k[1]) for k in ks])
    total = sum(k[1] - k[0] for k in ks)
    streams = {}
    for k in ks:
        streams.setdefault(k[2], []).append(k)
    per_stream = {}
    for sid, sk in streams.items():
        s_span = max(k[1] for k in sk) - sk[0][0]
        s_busy = union([(k[0], k[1]) for k in sk])
        per_stream[sid] = {"kernels": len(sk), "busy": s_busy,
                           "kernel": sum(k[1] - k[0] for k in sk), "span": s_span,
                           "gaps": s_span - s_busy}
    # the streams with at least long_stream kernels in the step (a backend's captured step)
    # against the others (graphs the device launches: a loop's bodies), each group's kernels,
    # their summed time and the union of their intervals
    groups = {}
    for g, keep in (("long", lambda n: n >= long_stream), ("short", lambda n: n < long_stream)):
        gk = [k for k in ks if keep(len(streams[k[2]]))]
        groups[g] = {"streams": sum(1 for sk in streams.values() if keep(len(sk))),
                     "kernels": len(gk), "kernel": sum(k[1] - k[0] for k in gk),
                     "busy": union([(k[0], k[1]) for k in gk])}
    by_name = {}
    for k in ks:
        n = short(names[k[3]])
        c = by_name.setdefault(n, [0, 0, 0])
        c[0] += 1
        c[1] += k[1] - k[0]
        c[2] += k[4]
    return {"span": span, "busy": busy, "kernel": total, "idle": span - busy,
            "kernels": len(ks), "streams": per_stream, "groups": groups, "names": by_name}


def median(xs):
    return statistics.median(xs) if xs else 0.0


def summarise(label, steps):
    ms = 1e-6
    out = {"label": label, "steps": len(steps)}
    for key in ("span", "busy", "kernel", "idle"):
        out[key + "_ms"] = median([s[key] for s in steps]) * ms
    out["kernels"] = median([s["kernels"] for s in steps])
    out["side_by_side"] = out["kernel_ms"] / out["busy_ms"] if out["busy_ms"] else 0.0
    out["stream_groups"] = {
        g: {"streams": median([s["groups"][g]["streams"] for s in steps]),
            "kernels": median([s["groups"][g]["kernels"] for s in steps]),
            "kernel_ms": median([s["groups"][g]["kernel"] for s in steps]) * ms,
            "busy_ms": median([s["groups"][g]["busy"] for s in steps]) * ms}
        for g in ("long", "short")}
    streams = sorted({sid for s in steps for sid in s["streams"]})
    rows = []
    for sid in streams:
        present = [s["streams"][sid] for s in steps if sid in s["streams"]]
        rows.append({"stream": sid, "steps": len(present),
                     "kernels": median([p["kernels"] for p in present]),
                     "kernel_ms": median([p["kernel"] for p in present]) * ms,
                     "span_ms": median([p["span"] for p in present]) * ms,
                     "gaps_ms": median([p["gaps"] for p in present]) * ms})
    rows.sort(key=lambda r: -r["span_ms"])
    out["stream_rows"] = rows
    totals = {}
    for s in steps:
        for n, (count, dur, threads) in s["names"].items():
            t = totals.setdefault(n, [0, 0, 0])
            t[0] += count
            t[1] += dur
            t[2] += threads
    out["names"] = {n: {"per_step": c / len(steps), "ms_per_step": d * ms / len(steps),
                        "mean_us": d / c / 1e3, "mean_threads": th / c}
                    for n, (c, d, th) in totals.items()}
    return out


def labels_from(bench_path, labels, count):
    if bench_path and labels:
        sys.exit("kernel_trace: --bench and --labels both name the phases; give one")
    if labels:
        names = labels.split(",")
        if len(names) != count:
            sys.exit(f"kernel_trace: --labels names {len(names)} phases, the trace holds {count} "
                     f"(check --gap and --step-kernel)")
        return names
    if not bench_path:
        return [f"phase {i}" for i in range(count)]
    try:
        with open(bench_path) as f:
            b = json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f"kernel_trace: --bench {bench_path}: {e}")
    names = []
    if "packed" in b:
        names.append("packed")
    if "packed_one_backend_per_scene" in b:
        names.append("packed_one_backend_per_scene")
    names += [s.get("label", s.get("task", "?")) for s in b.get("single", [])]
    if len(names) != count:
        sys.exit(f"kernel_trace: --bench {bench_path} names {len(names)} measurements, the "
                 f"trace holds {count} phases (check --gap and --step-kernel)")
    return names


def text_report(summary):
    lines = []
    for p in summary["phases"]:
        lines.append(f"== {p['label']}: {p['steps']} steps, medians per step")
        lines.append(f"   span {p['span_ms']:.2f} ms, busy {p['busy_ms']:.2f} ms, idle "
                     f"{p['idle_ms']:.2f} ms, kernels {p['kernels']:.0f} ({p['kernel_ms']:.2f} "
                     f"ms added up: {p['side_by_side']:.2f} side by side)")
        for g, what in (("long", f"streams of {summary['long_stream']}+ kernels a step"),
                        ("short", "the other streams")):
            v = p["stream_groups"][g]
            lines.append(f"   {what}: {v['streams']:.0f} streams, {v['kernels']:.0f} kernels, "
                         f"{v['kernel_ms']:.2f} ms added up, busy {v['busy_ms']:.2f} ms")
        lines.append("   stream        kernels  kernel ms  span ms  gaps ms")
        for r in p["stream_rows"][:summary["streams"]]:
            lines.append(f"   {r['stream']:>10}  {r['kernels']:>7.0f}  {r['kernel_ms']:>9.2f}  "
                         f"{r['span_ms']:>7.2f}  {r['gaps_ms']:>7.2f}")
        more = len(p["stream_rows"]) - summary["streams"]
        if more > 0:
            lines.append(f"   ... {more} more streams with shorter spans (kernel-trace.json)")
        lines.append("   kernel (shortened name)                          per step   ms/step  "
                     "mean us  threads")
        top = sorted(p["names"].items(), key=lambda kv: -kv[1]["ms_per_step"])
        for n, v in top[:summary["top"]]:
            lines.append(f"   {n[:50]:<50} {v['per_step']:>8.1f}  {v['ms_per_step']:>8.3f}  "
                         f"{v['mean_us']:>7.1f}  {v['mean_threads']:>7.0f}")
    if summary.get("compare"):
        c = summary["compare"]
        lines.append(f"== {c['packed']} against the mean of the {c['singles']} tasks alone "
                     f"(per step; each task alone steps all the slots)")
        for key in ("span_ms", "busy_ms", "kernel_ms", "idle_ms", "kernels"):
            lines.append(f"   {key:<10} packed {c['packed_' + key]:>10.2f}   alone "
                         f"{c['alone_' + key]:>10.2f}")
        lines.append("   kernel (shortened name)                          packed ms  alone ms  "
                     "packed - alone")
        for r in c["names"][:summary["top"]]:
            lines.append(f"   {r['name'][:50]:<50} {r['packed_ms']:>9.3f} {r['alone_ms']:>9.3f}  "
                         f"{r['extra_ms']:>+9.3f}")
    return "\n".join(lines) + "\n"


def compare(ph, packed_label):
    packed = next((p for p in ph if p["label"] == packed_label), None)
    singles = [p for p in ph if not p["label"].startswith("packed")]
    if packed is None or not singles:
        return None
    out = {"packed": packed_label, "singles": len(singles)}
    for key in ("span_ms", "busy_ms", "kernel_ms", "idle_ms", "kernels"):
        out["packed_" + key] = packed[key]
        out["alone_" + key] = sum(p[key] for p in singles) / len(singles)
    names = set(packed["names"])
    for p in singles:
        names |= set(p["names"])
    rows = []
    for n in names:
        a = sum(p["names"].get(n, {}).get("ms_per_step", 0.0) for p in singles) / len(singles)
        b = packed["names"].get(n, {}).get("ms_per_step", 0.0)
        rows.append({"name": n, "packed_ms": b, "alone_ms": a, "extra_ms": b - a})
    rows.sort(key=lambda r: -abs(r["extra_ms"]))
    out["names"] = rows
    return out


def main():
    a = parse()
    kernels, names, dropped, unstamped = read_trace(a.trace)
    groups = phases(kernels, names, a.step_kernel, int(a.gap * 1e9))
    labels = labels_from(a.bench, a.labels, len(groups))
    starts = [k[0] for k in kernels]
    ph = []
    for label, draws in zip(labels, groups):
        steps = []
        for i in range(a.skip, len(draws) - 1):
            lo, hi = draws[i][1], draws[i + 1][0]
            ks = kernels[bisect.bisect_left(starts, lo):bisect.bisect_left(starts, hi)]
            if ks:
                steps.append(step_stats(ks, names, a.long_stream))
        if not steps:
            sys.exit(f"kernel_trace: phase {label!r} has {len(draws)} draws, none left after "
                     f"--skip {a.skip}")
        ph.append(summarise(label, steps))
    summary = {"trace": os.path.basename(a.trace), "dropped_records": dropped,
               "unstamped_kernels": unstamped,
               "step_kernel": a.step_kernel, "skip": a.skip, "top": a.top, "streams": a.streams,
               "long_stream": a.long_stream,
               "phases": ph}
    if a.compare:
        c = compare(ph, "packed")
        if not c:
            sys.exit("kernel_trace: --compare needs a phase labelled packed and one or more "
                     "whose label does not start with packed")
        summary["compare"] = c
    os.makedirs(a.out, exist_ok=True)
    write_json(os.path.join(a.out, "kernel-trace.json"), summary, indent=1)
    write_text(os.path.join(a.out, "kernel-trace.txt"), text_report(summary))
    print(text_report(summary), end="")
    if dropped:
        print(f"kernel_trace: CUPTI dropped {dropped} records: the figures miss kernels",
              file=sys.stderr)


if __name__ == "__main__":
    main()
