"""The Python tests' autoreset and multi-agent checks on a CUDA device, where CI cannot run them
(it has no GPU; there they run on Warp's CPU device). The tests of python/tests/test_autoreset.py
that take a device run with device "cuda" (on catch_abreast, below) through a view that hands
their numpy actions to the env as torch tensors and its torch outputs back as numpy arrays; then
the multi-agent view is stepped with torch tensors against the vector env, as
python/tests/test_marl.py does on the CPU.

    python3 bench/python_cuda_check.py --out OUT.json

Writes OUT.json: each check's name, "passed" or the failure, the machine, date and command.
"""
import argparse
import datetime
import os
import subprocess
import sys
import traceback
import types

import numpy as np
import torch

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "python", "tests"))

import bidex  # noqa: E402
import test_autoreset  # noqa: E402
from atomic_io import write_json  # noqa: E402  (bench/atomic_io.py, beside this script)

# every check on the scene whose kernels the PPO example compiled (Warp caches them on disk): a
# new scene costs minutes of kernel compilation on the GPU machine
TASK = "catch_abreast"
ATOL = 0.05


def to_numpy(x):
    if isinstance(x, torch.Tensor):
        return x.detach().cpu().numpy()
    if isinstance(x, dict):
        return {k: to_numpy(v) for k, v in x.items()}
    if isinstance(x, tuple):
        return tuple(to_numpy(v) for v in x)
    return x


class NumpyView:
    """A CUDA env seen as the CPU tests see one: numpy in, numpy out (copied at each call)."""

    def __init__(self, env):
        self.env = env

    def __getattr__(self, name):
        return getattr(self.env, name)

    def reset(self, **kw):
        return to_numpy(self.env.reset(**kw))

    def step(self, a):
        return to_numpy(self.env.step(torch.as_tensor(np.asarray(a), device="cuda")))


def autoreset_checks():
    """The tests, with their module's bidex.make_vec giving numpy views of CUDA envs, and its
    comparison of two envs' values (`alike`) within ATOL: two envs on the GPU are not bitwise
    alike (MuJoCo Warp's atomic sums), so a mode compared with SAME_STEP agrees only closely.
    What one env holds (a held world's observation, zero rewards, flags) stays exact."""
    make = bidex.make_vec
    shim = types.SimpleNamespace(**vars(bidex))
    shim.make_vec = lambda task, *a, **kw: (NumpyView(make(TASK, *a, **kw))
                                            if kw.get("device") == "cuda" else make(task, *a, **kw))
    test_autoreset.bidex = shim
    test_autoreset.alike = lambda x, y: np.shape(x) == np.shape(y) and np.allclose(x, y, atol=ATOL)
    names = ("test_next_step_hands_back_the_last_observation_then_resets_in_the_next_step",
             "test_disabled_holds_ended_worlds_until_a_masked_reset")
    return [(n + "[cuda]", lambda f=getattr(test_autoreset, n): f("cuda")) for n in names]


def marl_check():
    marl = bidex.make_marl(TASK, 3, agents="finger", seed=5, device="cuda")
    vec = bidex.make_vec(TASK, 3, seed=5, device="cuda", copy=True)
    obs, _ = marl.reset()
    full, _ = vec.reset()
    assert torch.equal(marl.state(), full)  # the same seed's first observations: exact
    gen = torch.Generator(device="cuda").manual_seed(0)
    for _ in range(20):
        a = torch.rand(vec.action_space.shape, device="cuda", generator=gen) * 2 - 1
        per = {n: a[:, marl.split[n]["act_columns"]] for n in marl.agents}
        obs, rew, term, trunc, _ = marl.step(per)
        obs = {n: o.clone() for n, o in obs.items()}
        state = marl.state().clone()
        full, r, te, tr, _ = vec.step(a)
        assert isinstance(state, torch.Tensor) and state.device.type == "cuda"
        assert torch.allclose(state, full, atol=ATOL)
        for n in marl.agents:
            assert torch.equal(obs[n], state[:, marl.split[n]["obs_columns"]])
            assert torch.allclose(rew[n], r, atol=ATOL) and torch.equal(term[n], te)


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, help="the JSON to write")
    args = ap.parse_args()
    checks = autoreset_checks() + [("make_marl with torch tensors[cuda]", marl_check)]
    results = {}
    for name, f in checks:
        try:
            f()
            results[name] = "passed"
        except Exception:  # noqa: BLE001 - every failure is reported, the others still run
            results[name] = traceback.format_exc(limit=4)
        print(f"{name}: {results[name]}", flush=True)
    gpu = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"],
                         capture_output=True, text=True).stdout.strip()
    out = {"checks": results, "machine": gpu,
           "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
           "commit": os.environ.get("BIDEX_COMMIT", "unknown"),
           "command": "python3 bench/python_cuda_check.py --out " + args.out}
    write_json(args.out, out, indent=2)
    sys.exit(0 if all(v == "passed" for v in results.values()) else 1)


if __name__ == "__main__":
    main()
