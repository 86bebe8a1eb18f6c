#!/usr/bin/env python3
"""The Python loop's stepping rate on the GPU: a bidex vector env of --num-envs worlds on
--device (torch tensors over the GPU pack's rows), stepped with random actions made by torch on
the same device, best of --rounds timed rounds of --seconds (bench/python_gpu_run.sh sets it
beside `bidex bench warp`'s task step on the same task and world count, in one run).

    python bench/python_speed.py --task catch_abreast --num-envs 16384 --out speed.json
"""
import argparse
import datetime
import sys
import time

import torch

import bidex

from atomic_io import write_json  # bench/atomic_io.py, beside this script


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--task", default="catch_abreast")
    p.add_argument("--num-envs", type=int, default=16384)
    p.add_argument("--device", default="cuda")
    p.add_argument("--seconds", type=float, default=5.0)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--warmup", type=int, default=20, help="untimed steps first")
    p.add_argument("--out", required=True, help="JSON file (written atomically)")
    a = p.parse_args()
    env = bidex.make_vec(a.task, a.num_envs, device=a.device, seed=1)
    dev = torch.device(a.device)
    n, act = env.num_envs, env.single_action_space.shape[0]
    env.reset()
    gen = torch.Generator(device=dev).manual_seed(1)
    step = lambda: env.step(torch.rand(n, act, device=dev, generator=gen) * 2 - 1)
    for _ in range(a.warmup):
        step()
    rounds = []
    for _ in range(a.rounds):
        torch.cuda.synchronize(dev)
        t0, steps = time.perf_counter(), 0
        while time.perf_counter() - t0 < a.seconds:
            step()
            steps += 1
        torch.cuda.synchronize(dev)
        rounds.append(steps * n / (time.perf_counter() - t0))
        print(f"python loop: {a.task} {n} worlds: {rounds[-1]:,.0f} slot-steps/s", flush=True)
    out = {"task": a.task, "worlds": n, "device": torch.cuda.get_device_name(dev),
           "torch": torch.__version__, "slot_steps_per_s": max(rounds), "rounds": rounds,
           "seconds": a.seconds, "command": " ".join([sys.executable] + sys.argv),
           "date": datetime.datetime.now(datetime.timezone.utc).isoformat()}
    write_json(a.out, out, indent=2)


if __name__ == "__main__":
    main()
