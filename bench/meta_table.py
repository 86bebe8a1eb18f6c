#!/usr/bin/env python3
"""The meta-RL table beside the original's: for each suite and algorithm of a results folder
(bench/gpu_learn_run.sh meta: SUITE-ALGO/eval-{train,test}.json), the random policy's
random-SUITE-{train,test}.json (bidex eval --random --suite S --split P --json) and the zero
action's zero-SUITE-{train,test}.json (bidex eval --zero, likewise, with its normalised score):
the mean return before and after adaptation per split, next to the seed paper's ProMP, random and
single-task ground truth, and the normalised score after adaptation per split: the mean over the
tasks with both references in configs/registry/references.yaml (or $BIDEX_REFERENCES) of
(return - random) / (ground truth - random), with how many of the split's tasks it covers. The
original's ProMP row gets its normalised score from the original's own random and ground-truth
rows (its table reports suite means, so the score is of the means). A run folder's
eval-test-adaptN.json (bench/sweep_run.sh's SWEEP_META_ADAPT=N: N adaptation episodes, and N
gradient steps for MAML and ProMP) is a row of its own, so that the one-episode protocol stays
comparable. The folders may also be bench/sweep_run.sh's (SUITE-aALGO-...). Writes DIR/table.md
and DIR/summary.json. --baselines BDIR: the random and zero-action files are read from BDIR
(default DIR), e.g. the baselines measured once beside runs of a later lease. --suites S,S: only
those suites' rows (default ML1,ML4,ML20), e.g. a folder's suites whose rewards have not changed
since, normalised again with today's references; --out ODIR: table.md and summary.json go there
(made if missing) rather than into DIR, so that a folder's table of its time stays.
Usage: bench/meta_table.py DIR [--baselines BDIR] [--suites S,S] [--out ODIR]"""
import argparse
import json
import os
import sys

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from metrics_io import metrics_exists, read_metrics  # noqa: E402  (plain or .xz)
from atomic_io import write_json, write_text  # noqa: E402

SUITES = ["ML1", "ML4", "ML20"]

# the seed paper's meta-RL table: train / test mean returns
ORIGINAL = {
    "promp": {"ML1": (0.95, 1.2), "ML4": (2.5, 0.5), "ML20": (0.02, 0.36)},
    "random": {"ML1": (0.59, 0.68), "ML4": (1.5, 0.24), "ML20": (-2.9, 0.27)},
    "ground_truth": {"ML1": (15.0, 15.8), "ML4": (28.0, 13.1), "ML20": (33.7, 26.1)},
}


def load(path):
    return json.load(open(path)) if os.path.exists(path) else None


def last_row(d, name):
    """steps and wall_s of a run's last metrics row (when its summary.json is missing)"""
    path = os.path.join(d, name, "metrics.csv")
    if not metrics_exists(path):
        return None
    rows = read_metrics(path)
    return rows and {"steps": int(float(rows[-1]["steps"])), "wall_s": float(rows[-1]["wall_s"])}


def references():
    """{task: (random, ground truth or None)} of the references file"""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    path = os.environ.get("BIDEX_REFERENCES") or os.path.join(
        root, "configs", "registry", "references.yaml")
    doc = yaml.safe_load(open(path)) or {}
    value = lambda v: v["value"] if isinstance(v, dict) else v
    sec = lambda k: {t: value(v) for t, v in ((doc.get(k) or {}).get("values") or {}).items()}
    rnd, gt = sec("random"), sec("ground_truth")
    # named from the repository's root, wherever the script runs
    return {t: (r, gt.get(t)) for t, r in rnd.items()}, os.path.relpath(path, root)


def task_scores(ev, refs, key):
    """[(label, normalised score)] of an evaluation's entries with both references"""
    scores = []
    for e in ev["per_task"]:
        r, g = refs.get(e["task"], (None, None))
        if r is not None and g is not None and g != r:
            scores.append((e["label"], (e[key] - r) / (g - r)))
    return scores


def normalised(ev, refs, key):
    """(mean normalised score of an evaluation's entries with both references, count, entries)"""
    if not ev:
        return None, 0, 0
    scores = [v for _, v in task_scores(ev, refs, key)]
    return (sum(scores) / len(scores) if scores else None), len(scores), len(ev["per_task"])


def main(d, base=None, suites=SUITES, out=None):
    base = base or d
    refs, refs_path = references()
    algos = sorted({n.split("-", 1)[1] for n in os.listdir(d)
                    if os.path.isdir(os.path.join(d, n)) and "-" in n})
    rows, summary = [], {"what": __doc__.split("\n")[0], "original": ORIGINAL, "runs": [],
                         "references": refs_path}
    fmt = lambda v: "-" if v is None else f"{v:.3g}"
    cell = lambda n: "-" if n[0] is None else f"{n[0]:.3f} ({n[1]} of {n[2]})"
    for s in suites:
        rnd = {p: load(os.path.join(base, f"random-{s}-{p}.json")) for p in ("train", "test")}
        rows.append(f"| {s} | random (ours) | {fmt(rnd['train'] and rnd['train']['mean_return'])}"
                    f" | {fmt(rnd['test'] and rnd['test']['mean_return'])} | | | | |")
        zero = {p: load(os.path.join(base, f"zero-{s}-{p}.json")) for p in ("train", "test")}
        if any(zero.values()):
            zn = {p: normalised(zero[p], refs, "mean_return") for p in zero}
            rows.append(f"| {s} | zero action (ours) | "
                        f"{fmt(zero['train'] and zero['train']['mean_return'])} | "
                        f"{fmt(zero['test'] and zero['test']['mean_return'])} | | | "
                        f"{cell(zn['train'])} | {cell(zn['test'])} |")
            summary.setdefault("zero_action", {})[s] = {
                p: {"mean_return": zero[p] and zero[p]["mean_return"], "normalised": zn[p][0],
                    "tasks": zn[p][1], "of": zn[p][2],
                    "per_task": dict(task_scores(zero[p], refs, "mean_return")) if zero[p] else {}}
                for p in zero}
        for k in ("random", "promp", "ground_truth"):
            tr, te = ORIGINAL[k][s]
            own = ""
            if k == "promp":
                (rtr, rte), (gtr, gte) = ORIGINAL["random"][s], ORIGINAL["ground_truth"][s]
                own = f"{(tr - rtr) / (gtr - rtr):.3f} | {(te - rte) / (gte - rte):.3f}"
            rows.append(f"| {s} | {k} (original) | {tr} | {te} | | | {own or ' |'} |")
        for a in algos:
            ev = {p: load(os.path.join(d, f"{s}-{a}", f"eval-{p}.json")) for p in ("train", "test")}
            run = load(os.path.join(d, f"{s}-{a}", "summary.json")) or last_row(d, f"{s}-{a}")
            if not any(ev.values()):
                continue
            after = {p: ev[p] and ev[p]["return_after"] for p in ev}
            before = {p: ev[p] and ev[p]["return_before"] for p in ev}
            steps = f"{run['steps'] / 1e6:.1f}M" if run else "-"
            norm = {p: normalised(ev[p], refs, "return_after") for p in ev}
            rows.append(f"| {s} | {a} (ours, {steps} slot-steps) | {fmt(after['train'])} | "
                        f"{fmt(after['test'])} | {fmt(before['train'])} | {fmt(before['test'])} | "
                        f"{cell(norm['train'])} | {cell(norm['test'])} |")
            summary["runs"].append({
                "suite": s, "algo": a,
                "slot_steps": run and run["steps"], "wall_s": run and run["wall_s"],
                "train": ev["train"], "test": ev["test"],
                "normalised_after": {p: {"mean": norm[p][0], "tasks": norm[p][1],
                                         "of": norm[p][2]} for p in norm},
                "random": {p: rnd[p] and rnd[p]["mean_return"] for p in rnd}})
            # more adaptation on the test split (bench/sweep_run.sh's SWEEP_META_ADAPT): own rows
            for name in sorted(n for n in os.listdir(os.path.join(d, f"{s}-{a}"))
                               if n.startswith("eval-test-adapt") and n.endswith(".json")):
                more = load(os.path.join(d, f"{s}-{a}", name))
                n = normalised(more, refs, "return_after")
                k = name[len("eval-test-adapt"):-len(".json")]
                rows.append(f"| {s} | {a}, {k} adaptation episodes (ours, {steps} slot-steps) | - | "
                            f"{fmt(more['return_after'])} | - | {fmt(more['return_before'])} | - | "
                            f"{cell(n)} |")
                summary["runs"][-1].setdefault("test_more_adaptation", {})[k] = {
                    "eval": more, "normalised_after": {"mean": n[0], "tasks": n[1], "of": n[2]}}
    table = ["| suite | policy | train (after) | test (after) | train (before) | test (before) "
             "| train normalised (after) | test normalised (after) |",
             "|---|---|---|---|---|---|---|---|"] + rows
    out = out or d
    os.makedirs(out, exist_ok=True)
    write_text(os.path.join(out, "table.md"), "\n".join(table) + "\n")
    write_json(os.path.join(out, "summary.json"), summary, indent=2)
    print("\n".join(table))


def suite_list(text):
    names = [s for s in text.split(",") if s]
    bad = [s for s in names if s not in SUITES]
    if bad or not names:
        raise argparse.ArgumentTypeError(
            f"expected suites from {','.join(SUITES)} separated by commas, got '{text}'")
    return names


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 epilog=__doc__.rsplit("\n", 1)[-1])
    ap.add_argument("dir", help="the results folder (SUITE-ALGO/ run folders)")
    ap.add_argument("--baselines", help="the random and zero-action files' folder (default DIR)")
    ap.add_argument("--suites", type=suite_list, default=SUITES,
                    help="the suites drawn, comma-separated (default ML1,ML4,ML20)")
    ap.add_argument("--out", help="where table.md and summary.json go (default DIR)")
    a = ap.parse_args()
    for flag, folder in (("DIR", a.dir), ("--baselines", a.baselines)):
        if folder is not None and not os.path.isdir(folder):
            sys.exit(f"meta_table: {flag}: {folder} is not a folder")
    main(a.dir, a.baselines, a.suites, a.out)
