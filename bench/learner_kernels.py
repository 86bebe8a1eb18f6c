#!/usr/bin/env python3
"""Where PPO's act step and minibatch step spend the GPU's time (issue 39): the kernels of each,
from PyTorch's profiler, on networks of bidex's shapes.

The steps are rebuilt here in PyTorch with the shapes and operations of rl/onpolicy.cc (act:
the float64 observation normaliser's update, normalising, the actor's mean and the critic's
value, a Gaussian sample and its log-probability) and rl/ppo.cc (a minibatch: gathering rows,
both networks forward and backward under bfloat16 autocast or in TF32, the clipped surrogate,
the value loss, the gradient norm and Adam over one flat buffer), so that the kernels' shares
can be read without a profiler build of LibTorch. The numbers are PyTorch's, not bidex's: they
say which kernels cost the time, not bidex's exact step time (profile.json says that).

    python3 bench/learner_kernels.py --out DIR [--slots 16384] [--obs 422] [--act 52]
        [--minibatches 16] [--horizon 8] [--replays 50]

writes DIR/learner-kernels.json (each step's milliseconds eagerly and replayed as a CUDA graph,
and the kernels' summed CUDA time by name) and DIR/learner-kernels.txt (the profiler tables).
Needs PyTorch with CUDA and a GPU.
"""
import argparse
import json
import math
import os
import platform
import subprocess
import sys
import time

from atomic_io import write_text


def parse():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="folder for learner-kernels.{json,txt}")
    p.add_argument("--slots", type=int, default=16384)
    p.add_argument("--obs", type=int, default=422, help="observation width (catch_abreast: 422)")
    p.add_argument("--act", type=int, default=52)
    p.add_argument("--hidden", default="1024,1024,512")
    p.add_argument("--horizon", type=int, default=8)
    p.add_argument("--minibatches", type=int, default=16)
    p.add_argument("--replays", type=int, default=50, help="timed calls of each step")
    return p.parse_args()


def main():
    a = parse()
    try:
        import torch
    except ImportError:
        sys.exit("learner_kernels: PyTorch is not installed (pip install torch)")
    if not torch.cuda.is_available():
        sys.exit("learner_kernels: no CUDA device")
    from torch import nn
    from torch.profiler import ProfilerActivity, profile

    torch.backends.cuda.matmul.allow_tf32 = True
    torch.backends.cudnn.allow_tf32 = True
    dev = torch.device("cuda")
    hidden = [int(h) for h in a.hidden.split(",")]

    def mlp(out):
        layers, w = [], a.obs
        for h in hidden:
            layers += [nn.Linear(w, h), nn.ELU()]
            w = h
        layers.append(nn.Linear(w, out))
        return nn.Sequential(*layers).to(dev)

    actor, critic = mlp(a.act), mlp(1)
    log_std = nn.Parameter(torch.zeros(a.act, device=dev))
    params = list(actor.parameters()) + list(critic.parameters()) + [log_std]
    # FlatAdam's layout: every parameter and gradient a view of one buffer
    flat = torch.cat([p.detach().reshape(-1) for p in params])
    gflat = torch.zeros_like(flat)
    at = 0
    for p in params:
        n = p.numel()
        p.data = flat[at:at + n].view_as(p)
        p.grad = gflat[at:at + n].view_as(p)
        at += n
    m1, m2 = torch.zeros_like(flat), torch.zeros_like(flat)
    step_t = torch.zeros((), device=dev, dtype=torch.float64)
    lr = torch.full((), 3e-4, device=dev, dtype=torch.float64)

    N, D, A, T = a.slots, a.obs, a.act, a.horizon
    count = torch.zeros(1, device=dev, dtype=torch.float64)
    mean = torch.zeros(D, device=dev, dtype=torch.float64)
    var = torch.ones(D, device=dev, dtype=torch.float64)
    obs = torch.randn(N, D, device=dev)
    ro = {k: torch.zeros(T, N, w, device=dev) for k, w in
          (("nobs", D), ("actions", A), ("mu", A))}
    ro.update({k: torch.zeros(T, N, device=dev) for k in ("values", "logp")})

    def logp_of(x, mu, ls):
        z = (x - mu) * torch.exp(-ls)
        return (-0.5 * z.pow(2) - ls - 0.5 * math.log(2 * math.pi)).sum(-1)

    def act_step(t=0):
        with torch.no_grad():
            xd = obs.to(torch.float64)
            n = torch.full_like(count, float(N))
            bm, bv = xd.mean(0), xd.var(0, unbiased=False)
            total = count + n
            delta = bm - mean
            m2_ = var * count + bv * n + delta.pow(2) * count * n / total
            mean.copy_(mean + delta * n / total)
            var.copy_(m2_ / total)
            count.copy_(total)
            s = (var + 1e-8).sqrt().float()
            nobs = ((obs - mean.float()) / s).clamp(-5, 5)
            mu = actor(nobs)
            v = critic(nobs).squeeze(-1)
            x = mu + torch.exp(log_std) * torch.randn_like(mu)
            ro["nobs"][t].copy_(nobs)
            ro["actions"][t].copy_(x)
            ro["mu"][t].copy_(mu)
            ro["values"][t].copy_(v)
            ro["logp"][t].copy_(logp_of(x, mu, log_std))

    B = N * T
    mb = B // a.minibatches
    rows = {k: v.reshape(B, -1) for k, v in ro.items()}
    adv = torch.randn(B, device=dev)
    tgt = torch.randn(B, device=dev)
    idx = torch.randperm(B, device=dev)[:mb]

    def minibatch(bf16):
        o = rows["nobs"].index_select(0, idx)
        x = rows["actions"].index_select(0, idx)
        with torch.autocast("cuda", dtype=torch.bfloat16, enabled=bf16, cache_enabled=False):
            mu = actor(o).float()
            v = critic(o).float().squeeze(-1)
        lp = logp_of(x, mu, log_std)
        ratio = torch.exp(lp - rows["logp"].index_select(0, idx).squeeze(-1))
        ad = adv.index_select(0, idx)
        pl = -torch.min(ratio * ad, ratio.clamp(0.8, 1.2) * ad).mean()
        vl = (v - tgt.index_select(0, idx)).pow(2).mean()
        loss = pl + 2.0 * vl
        gflat.zero_()
        loss.backward()
        norm = gflat.norm()
        gflat.mul_((1.0 / (norm + 1e-6)).clamp(max=1.0))
        step_t.add_(1)
        m1.mul_(0.9).add_(gflat, alpha=0.1)
        m2.mul_(0.999).addcmul_(gflat, gflat, value=0.001)
        bc1 = 1 - torch.pow(0.9, step_t)
        bc2 = 1 - torch.pow(0.999, step_t)
        flat.sub_((lr / bc1).float() * m1 / (m2.sqrt() / bc2.sqrt().float() + 1e-8))

    steps = {"act": lambda: act_step(0), "minibatch_tf32": lambda: minibatch(False),
             "minibatch_bf16": lambda: minibatch(True)}
    result = {"what": "PPO's act and minibatch steps rebuilt in PyTorch with bidex's shapes "
                      "(bench/learner_kernels.py): milliseconds a call and the CUDA time of "
                      "their kernels by name",
              "command": "python3 " + " ".join(sys.argv),
              "machine": machine(torch), "shapes": {"slots": N, "obs": D, "act": A,
                                                    "hidden": hidden, "minibatch_rows": mb},
              "steps": {}}
    tables = []
    for name, fn in steps.items():
        side = torch.cuda.Stream()
        side.wait_stream(torch.cuda.current_stream())
        with torch.cuda.stream(side):
            for _ in range(3):
                fn()  # warm: cuBLAS's workspace and autograd's threads before a capture
        torch.cuda.current_stream().wait_stream(side)
        torch.cuda.synchronize()
        eager_ms = timed(torch, fn, a.replays)
        g = torch.cuda.CUDAGraph()
        with torch.cuda.graph(g):
            fn()
        graph_ms = timed(torch, g.replay, a.replays)
        with profile(activities=[ProfilerActivity.CUDA]) as prof:
            for _ in range(10):
                g.replay()
            torch.cuda.synchronize()
        kernels = {}
        for e in prof.key_averages():
            t = getattr(e, "device_time_total", None)
            if t is None:
                t = e.cuda_time_total
            if t > 0:
                kernels[e.key] = round(t / 10 / 1000, 4)  # ms a replay
        kernels = dict(sorted(kernels.items(), key=lambda kv: -kv[1]))
        result["steps"][name] = {"eager_ms": round(eager_ms, 4), "graph_ms": round(graph_ms, 4),
                                 "kernel_ms_per_replay": kernels,
                                 "kernel_ms_sum": round(sum(kernels.values()), 4)}
        tables.append(f"== {name}: eager {eager_ms:.3f} ms, graph {graph_ms:.3f} ms\n" +
                      prof.key_averages().table(sort_by="cuda_time_total", row_limit=25))
        print(f"{name}: eager {eager_ms:.3f} ms, graph {graph_ms:.3f} ms, "
              f"kernels {sum(kernels.values()):.3f} ms", flush=True)
    os.makedirs(a.out, exist_ok=True)
    write_text(os.path.join(a.out, "learner-kernels.json"), json.dumps(result, indent=1) + "\n")
    write_text(os.path.join(a.out, "learner-kernels.txt"), "\n".join(tables))


def timed(torch, fn, n):
    torch.cuda.synchronize()
    t0 = time.perf_counter()
    for _ in range(n):
        fn()
    torch.cuda.synchronize()
    return (time.perf_counter() - t0) / n * 1000


def machine(torch):
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, check=False).stdout.strip()
    except OSError:
        commit = ""
    return {"date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "commit": os.environ.get("BIDEX_COMMIT", commit) or "unknown",
            "gpu": torch.cuda.get_device_name(0), "torch": torch.__version__,
            "host": platform.node(), "cpu_count": os.cpu_count()}


if __name__ == "__main__":
    main()
