#!/usr/bin/env python3
"""Which scenes of a suite could share one MuJoCo Warp Model (issue 39, item 4: suites packed
by topology). Writes each task's scene with `bidex model --task ID --gpu`, groups the scenes
whose topology is the same (every size, the body tree, the joint, dof, geom, site, actuator,
equality, sensor and contact-pair layouts and types), and lists for each group of two or more
every MjModel field whose values differ inside it, with whether MuJoCo Warp's Model can hold
that field per world (a leading '*' dimension in its type, read as field[world % n]).

With --check-steps N, each such group is also stepped as one Model on Warp's CPU device, with
per-world values for the fields that differ (world i plays scene i), beside each scene's own
Model with as many worlds under the same random controls: world i of the packed Model against
world i of scene i's own (the same world count, so the same arithmetic) says whether the packed
worlds are the scenes' own; the spread between the packed worlds, that they differ.

With --estimate FILE..., `bidex bench pack` results of the suite on a GPU (its JSON files, one
per slot count) give a rough gain: a fit of the packed step's time as (Models x a) + (slots x b),
a fixed cost per Model and one per world, then the same at the count of topologies.

From the repository (mujoco and mujoco_warp come from .venv/, where scripts/setup.sh puts them):
  bench/pack_topology.py --suite MT20 [--check-steps 480] [--estimate PACK.json...] [--json OUT]
"""
import argparse, dataclasses, datetime, glob, json, os, platform, subprocess, sys, tempfile

import yaml

try:
    import mujoco
except ImportError:  # the pinned wheels of .venv/, beside this Python's own packages
    sys.path[:0] = glob.glob(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..",
                                          ".venv", "lib", "python3*", "site-packages"))
    try:
        import mujoco
    except ImportError:
        sys.exit("pack_topology: needs the mujoco package of .venv/ (scripts/setup.sh)")
import numpy as np

from atomic_io import write_json  # bench/atomic_io.py, beside this script

# arrays that describe a scene's structure: equal in every scene of a group
STRUCTURE = ["body_parentid", "body_mocapid", "body_jntnum", "body_dofnum", "body_geomnum",
             "body_weldid", "jnt_type", "jnt_bodyid", "dof_parentid", "geom_type", "geom_bodyid",
             "site_bodyid", "actuator_trntype", "actuator_trnid", "actuator_dyntype",
             "actuator_gaintype", "actuator_biastype", "eq_type", "eq_obj1id", "eq_obj2id",
             "sensor_type", "sensor_objid", "pair_geom1", "pair_geom2", "geom_contype",
             "geom_conaffinity", "exclude_signature"]
# sizes that only count names, text and the like
NOT_SIZES = {"nnames", "npaths", "ntext", "ntextdata", "ntuple", "ntupledata", "nnumeric",
             "nnumericdata", "nbuffer", "nnames_map", "narena", "nuser_body"}


def suite_tasks(name):
    path = os.path.join("configs", "suites", f"{name}.yaml")
    if not os.path.exists(path):
        sys.exit(f"pack_topology: {path} not found (--suite names a suite of configs/suites)")
    train = (yaml.safe_load(open(path)) or {}).get("train") or []
    out = []
    for m in train:
        if m["task"] not in out:
            out.append(m["task"])
    return out


def write_scenes(bidex, tasks, folder):
    for t in tasks:
        xml = os.path.join(folder, f"{t}.xml")
        r = subprocess.run([bidex, "model", "--task", t, "--gpu", "--out", xml],
                           capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"pack_topology: `{bidex} model --task {t}` failed:\n{r.stdout}{r.stderr}")
    return {t: os.path.join(folder, f"{t}.xml") for t in tasks}


def arrays(m):
    """every numeric field of an MjModel (and of its options, as opt.NAME) as an array"""
    out = {}
    for owner, prefix in ((m, ""), (m.opt, "opt.")):
        for k in dir(owner):
            if k.startswith("_"):
                continue
            try:
                v = getattr(owner, k)
            except Exception:  # noqa: BLE001  (some properties refuse to be read)
                continue
            if isinstance(v, np.ndarray) or (isinstance(v, (int, float)) and not isinstance(v, bool)):
                out[prefix + k] = np.asarray(v)
    return out


def signature(f):
    sizes = sorted(k for k in f if k.startswith("n") and "." not in k and f[k].ndim == 0
                   and k not in NOT_SIZES)
    return tuple((k, f[k].tobytes()) for k in sizes + [s for s in STRUCTURE if s in f])


def quiet_warp():
    """Warp without its banner and module-load lines (as sim/warp_bridge.py), on its CPU device"""
    import warp as wp
    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    wp.set_device("cpu")
    return wp


def per_world_fields():
    """{field: True when MuJoCo Warp's Model (or Option, as opt.NAME) holds it per world}"""
    quiet_warp()
    from mujoco_warp._src import types as mjwt
    out = {}
    for cls, prefix in ((mjwt.Model, ""), (mjwt.Option, "opt.")):
        for f in dataclasses.fields(cls):
            shape = getattr(f.type, "shape", None)
            out[prefix + f.name] = bool(shape) and shape[0] == "*"
    return out


def differing(fields, group):
    out = []
    for k in sorted(set.intersection(*(set(fields[t]) for t in group))):
        if k.startswith("name_") or k in ("names", "names_map", "signature"):
            continue
        a = [fields[t][k] for t in group]
        if all(x.shape == a[0].shape and np.array_equal(a[0], x, equal_nan=True) for x in a[1:]):
            continue
        same_shape = all(x.shape == a[0].shape for x in a)
        diff = (max(float(np.abs(x.astype(float) - a[0].astype(float)).max()) for x in a[1:])
                if same_shape else None)
        out.append((k, diff))
    return out


def check_group(models, steps, seed=0):
    """the group stepped as one Warp Model (CPU device) against each scene's own Model with as many
    worlds: (fields given per-world values, max over i of |qpos of packed world i - world i of
    scene i's own|, max |qpos world i - world 0| of the packed Model)"""
    wp = quiet_warp()
    import mujoco_warp as mjw
    from mujoco_warp._src import types as mjwt
    per_world = {f.name for f in dataclasses.fields(mjwt.Model)
                 if getattr(f.type, "shape", None) and f.type.shape[0] == "*"}

    def put(m, **kw):
        w = mjw.put_model(m, **kw)
        w.opt.disableflags = w.opt.disableflags | int(mjw.DisableBit.NATIVECCD)  # as sim/warp_bridge.py
        return w

    n = len(models)
    own = [put(m) for m in models]
    batched = [f for f in sorted(per_world) if isinstance(getattr(own[0], f), wp.array)
               and not all(np.array_equal(getattr(own[0], f).numpy(), getattr(o, f).numpy())
                           for o in own[1:])]
    packed = put(models[0], batch_sizes={f: n for f in batched})
    for f in batched:
        getattr(packed, f).assign(np.concatenate([getattr(o, f).numpy() for o in own]))
    d = mjw.put_data(models[0], mujoco.MjData(models[0]), nworld=n, njmax=192, nconmax=64)
    mjw.reset_data(packed, d)  # each world's initial state from its own values
    ds = [mjw.put_data(m, mujoco.MjData(m), nworld=n, njmax=192, nconmax=64) for m in models]
    rng = np.random.default_rng(seed)
    lo, hi = models[0].actuator_ctrlrange.T
    for _ in range(steps):
        ctrl = (lo + (hi - lo) * rng.random((n, models[0].nu))).astype(np.float32)
        d.ctrl.assign(ctrl)
        mjw.step(packed, d)
        for i in range(n):
            ds[i].ctrl.assign(ctrl)
            mjw.step(own[i], ds[i])
    q = d.qpos.numpy()
    worst = max(float(np.abs(q[i] - ds[i].qpos.numpy()[i]).max()) for i in range(n))
    return batched, worst, float(np.abs(q - q[0]).max())


def estimate(files, models_after):
    """[(slots, measured, fitted, predicted slot-steps/s at models_after Models, its ratio to the
    mean single task)] and (a, b) from `bidex bench pack` JSON files"""
    rows = []
    for f in files:
        d = json.load(open(f))
        n = len(d["single"])
        slots = int(d["command"].split("--slots")[1].split()[0])
        rows.append((slots, n, d["packed"]["slot_steps_per_s"], d["mean_single_slot_steps_per_s"]))
    A = np.array([[n, s] for s, n, _, _ in rows], float)
    t = np.array([s / r for s, _, r, _ in rows])  # seconds per control step of every world
    (a, b), *_ = np.linalg.lstsq(A, t, rcond=None)
    out = []
    for s, n, r, single in sorted(rows):
        fit = s / (n * a + s * b)
        after = s / (models_after * a + s * b)
        out.append((s, n, r, fit, after, after / single, r / single))
    return out, (a, b)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--suite", default="MT20")
    ap.add_argument("--tasks", help="comma-separated task ids instead of a suite's")
    ap.add_argument("--bidex", default="build/apps/bidex")
    ap.add_argument("--check-steps", type=int, default=0,
                    help="physics steps of each group packed on Warp's CPU device (0: none)")
    ap.add_argument("--estimate", nargs="+", metavar="PACK_JSON",
                    help="bidex bench pack results of the suite: the gain's rough estimate")
    ap.add_argument("--json", help="also write the result as JSON here")
    a = ap.parse_args()
    if not os.path.exists(a.bidex):
        sys.exit(f"pack_topology: --bidex {a.bidex} not found (build bidex first)")
    tasks = a.tasks.split(",") if a.tasks else suite_tasks(a.suite)
    with tempfile.TemporaryDirectory() as tmp:
        models = {t: mujoco.MjModel.from_xml_path(p) for t, p in write_scenes(a.bidex, tasks, tmp).items()}
    fields = {t: arrays(m) for t, m in models.items()}
    groups = {}
    for t in tasks:
        groups.setdefault(signature(fields[t]), []).append(t)
    groups = sorted(groups.values(), key=lambda g: (-len(g), tasks.index(g[0])))
    per_world = per_world_fields()
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    result = {"command": " ".join(["bench/pack_topology.py"] + sys.argv[1:]), "commit": commit,
              "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
              "machine": f"{platform.node()}, {os.cpu_count()} cores, Warp's CPU device",
              "mujoco": mujoco.__version__, "tasks": tasks, "models_after_packing": len(groups),
              "groups": []}
    print(f"{len(tasks)} scenes, {len(groups)} topologies "
          f"({sum(len(g) > 1 for g in groups)} groups of two or more)\n")
    for g in groups:
        entry = {"tasks": g, "differing": []}
        print(f"- {len(g)}: {', '.join(g)}")
        if len(g) > 1:
            for k, diff in differing(fields, g):
                where = ("per world" if per_world.get(k) else "shared") if k in per_world \
                    else "not in MuJoCo Warp's Model"
                entry["differing"].append({"field": k, "max_abs_diff": diff, "mujoco_warp": where})
                print(f"    {k:24s} max |diff| {'' if diff is None else f'{diff:.3g}':10s} {where}")
            if a.check_steps:
                batched, worst, spread = check_group([models[t] for t in g], a.check_steps)
                entry["check"] = {"steps": a.check_steps, "per_world_fields": batched,
                                  "max_qpos_diff_packed_vs_own": worst,
                                  "max_qpos_spread_between_worlds": spread}
                print(f"    packed on Warp's CPU device, {a.check_steps} steps, per-world "
                      f"{', '.join(batched)}: max |qpos packed - own Model| {worst:.3g}; "
                      f"between the worlds {spread:.3g}")
        result["groups"].append(entry)
    if a.estimate:
        rows, (fa, fb) = estimate(a.estimate, len(groups))
        print(f"\nestimate from {len(rows)} bench pack runs: a step costs {fa * 1e3:.2f} ms per "
              f"Model and {fb * 1e6:.2f} us per world")
        print("| slots | Models | measured slot-steps/s | fit | at "
              f"{len(groups)} Models | packed / mean single task: measured | at {len(groups)} Models |")
        print("|---|---|---|---|---|---|---|")
        for s_, n, r, fit, after, ratio_after, ratio in rows:
            print(f"| {s_:,} | {n} | {r:,.0f} | {fit:,.0f} | {after:,.0f} | {ratio:.3f} | {ratio_after:.3f} |")
        result["estimate"] = {"ms_per_model": fa * 1e3, "us_per_world": fb * 1e6, "files": a.estimate,
                              "rows": [dict(zip(("slots", "models", "measured", "fit", "predicted",
                                                 "predicted_over_single", "measured_over_single"),
                                                x)) for x in rows]}
    if a.json:
        write_json(a.json, result, indent=1)


if __name__ == "__main__":
    main()
