#!/usr/bin/env python3
"""PPO in PyTorch on a bidex Gymnasium vector environment, in one file.

    python examples/ppo_torch.py --task catch_abreast --num-envs 16384 --device cuda \
        --steps 30000000 --minibatches 16 --seed 0 --out runs/ppo-torch --target 43.4

It mirrors bidex's own C++ PPO (rl/ppo.cc, rl/onpolicy.cc, rl/policy.cc, configs/train/ppo.yaml)
so that it learns the same way:
  - separate actor and critic MLPs (ELU), orthogonal weights (gain sqrt 2, actor output 0.01,
    critic output 1), zero biases; a learned state-independent log-std, log(init_std);
  - running mean/variance of observations (float64, Chan's merge, count starts at 1e-4), updated
    with every batch the policy acts on, normalised as clamp((x - mean) / sqrt(var + 1e-8), +-5);
    the rollout keeps the observations as the policy saw them;
  - actions: the unclipped sample mu + std * N(0, 1) is stored and sent (the env clips to
    [-1, 1]); the rollout's Gaussian keeps the log-std it started with;
  - done = terminated or truncated cuts GAE; a time limit (truncated, not a fault) adds
    gamma * V(final_obs) to that step's reward;
  - advantages normalised once over the whole batch ((A - mean) / (std + 1e-8)); returns = GAE
    advantages + values; clipped surrogate, plain MSE value loss times value_coef, entropy bonus;
  - one Adam over all parameters, gradient norm clipped to max_grad_norm;
  - adaptive learning rate checked before every minibatch's step: KL(old || new) of the
    diagonal Gaussians, mean over the minibatch; KL > 2 desired: lr / 1.5 (at least 1e-5);
    0 < KL < desired / 2: lr * 1.5 (at most 1e-2);
  - TF32 matmuls on CUDA (torch.set_float32_matmul_precision("high"), as the C++ sets it).
Differences: no value normalisation and no clipped value loss (both off in ppo.yaml, so not
offered here), no checkpoints or resume, no per-term reward columns; the episode statistics are
summed from the env's infos (the same episodes the core's counters count, faulted ones included).
A world that ended this step is bootstrapped through a masked critic pass over all final_obs
rows (no host sync) where the C++ gathers the truncated rows first: the same values.

Outputs in --out: metrics.csv (one row per update), summary.json, and with --plot curve.svg and
curve.png (when matplotlib is importable). "mean_return" is the mean over the episodes of the
newest whole updates that hold at least 100 episodes (the rule bench/sweep_collect.py uses for
"first reached", after the original's logged mean of its last 100 episodes); the summary's
"final_mean_return" is the mean over the episodes of the last 10 updates (the C++ summary's).
"""
import argparse
import csv
import datetime
import io
import json
import math
import os
import statistics
import sys
import time

import torch
import torch.nn as nn

import bidex

LOG_2PI = math.log(2 * math.pi)


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    a = p.add_argument
    a("--task", default="catch_abreast", help="bidex task id (bidex.task_ids())")
    a("--num-envs", type=int, default=2048, help="parallel worlds")
    a("--device", default="cuda" if torch.cuda.is_available() else "cpu", help="learner device")
    a("--env-device", default=None, help="device of the env (default: --device)")
    a("--threads", type=int, default=0, help="the CPU env's core threads (0: all cores)")
    a("--steps", type=int, default=100_000_000, help="slot-steps in total")
    a("--seed", type=int, default=0)
    a("--out", required=True, help="output folder")
    a("--target", type=float, default=None, help="report when mean_return first reaches this")
    a("--stop-at-target", action="store_true", help="stop once --target is reached")
    a("--plot", action="store_true", help="write curve.svg/png (needs matplotlib)")
    a("--log-every", type=int, default=10, help="updates between progress lines")
    # PPO (configs/train/ppo.yaml)
    a("--hidden", type=int, nargs="+", default=[1024, 1024, 512])
    a("--activation", choices=["elu", "relu", "tanh"], default="elu")
    a("--init-std", type=float, default=0.8)
    a("--horizon", type=int, default=8)
    a("--epochs", type=int, default=5)
    a("--minibatches", type=int, default=4)
    a("--clip", type=float, default=0.2)
    a("--lr", type=float, default=3e-4)
    a("--schedule", choices=["adaptive", "fixed"], default="adaptive")
    a("--desired-kl", type=float, default=0.016)
    a("--gamma", type=float, default=0.96)
    a("--lam", type=float, default=0.95)
    a("--max-grad-norm", type=float, default=1.0)
    a("--entropy-coef", type=float, default=0.0)
    a("--value-coef", type=float, default=2.0)
    a("--no-obs-norm", dest="obs_norm", action="store_false")
    a("--no-tf32", dest="tf32", action="store_false")
    return p.parse_args(argv)


class RunningNorm(nn.Module):
    """Running mean and population variance (float64, Chan's parallel merge), rl/policy.cc."""

    def __init__(self, dim, clip=5.0):
        super().__init__()
        self.clip = clip
        self.register_buffer("mean", torch.zeros(dim, dtype=torch.float64))
        self.register_buffer("var", torch.ones(dim, dtype=torch.float64))
        self.register_buffer("count", torch.full((1,), 1e-4, dtype=torch.float64))

    @torch.no_grad()
    def update(self, x):
        x = x.double().reshape(-1, self.mean.numel())
        n, bmean, bvar = x.shape[0], x.mean(0), x.var(0, unbiased=False)
        total = self.count + n
        delta = bmean - self.mean
        m2 = self.var * self.count + bvar * n + delta.pow(2) * self.count * n / total
        self.mean += delta * n / total
        self.var.copy_(m2 / total)
        self.count.copy_(total)

    def forward(self, x):
        s = (self.var + 1e-8).sqrt().to(x.dtype)
        return ((x - self.mean.to(x.dtype)) / s).clamp(-self.clip, self.clip)


def mlp(inp, hidden, out, activation, out_gain):
    act = {"elu": nn.ELU, "relu": nn.ReLU, "tanh": nn.Tanh}[activation]
    layers, width = [], inp
    for h in hidden:
        layers += [nn.Linear(width, h), act()]
        width = h
    layers.append(nn.Linear(width, out))
    for i, m in enumerate(l for l in layers if isinstance(l, nn.Linear)):
        nn.init.orthogonal_(m.weight, math.sqrt(2.0) if i < len(hidden) else out_gain)
        nn.init.zeros_(m.bias)
    return nn.Sequential(*layers)


class ActorCritic(nn.Module):
    def __init__(self, obs_dim, act_dim, args):
        super().__init__()
        self.actor = mlp(obs_dim, args.hidden, act_dim, args.activation, 0.01)
        self.critic = mlp(obs_dim, args.hidden, 1, args.activation, 1.0)
        self.log_std = nn.Parameter(torch.full((act_dim,), math.log(args.init_std)))
        self.obs_norm = RunningNorm(obs_dim) if args.obs_norm else nn.Identity()

    def value(self, nobs):
        return self.critic(nobs).squeeze(-1)


def log_prob(a, mu, log_std):
    return (-0.5 * ((a - mu) * torch.exp(-log_std)).pow(2) - log_std - 0.5 * LOG_2PI).sum(-1)


def kl_divergence(mu_old, log_std_old, mu, log_std):  # KL(old || new), summed over actions
    var_old, var = torch.exp(2 * log_std_old), torch.exp(2 * log_std)
    return (log_std - log_std_old + (var_old + (mu_old - mu).pow(2)) / (2 * var) - 0.5).sum(-1)


@torch.no_grad()
def gae(rewards, values, dones, last_value, gamma, lam):
    adv, running = torch.zeros_like(rewards), torch.zeros_like(last_value)
    for t in reversed(range(rewards.shape[0])):
        next_value = last_value if t == rewards.shape[0] - 1 else values[t + 1]
        alive = 1.0 - dones[t]
        delta = rewards[t] + gamma * next_value * alive - values[t]
        running = delta + gamma * lam * alive * running
        adv[t] = running
    return adv, adv + values


def ppo_update(model, opt, ro, last_value, args, lr):
    """Epochs x minibatches over one rollout (rl/ppo.cc Ppo::update); returns stats and the lr."""
    adv, ret = gae(ro["rewards"], ro["values"], ro["dones"], last_value, args.gamma, args.lam)
    B = adv.numel()
    flat = {k: ro[k].reshape(B, -1).squeeze(-1) for k in ("nobs", "actions", "logp", "mu")}
    adv, ret = adv.reshape(B), ret.reshape(B)
    adv = (adv - adv.mean()) / (adv.std() + 1e-8)
    log_std_old, mb = ro["log_std"], B // args.minibatches
    sums, kls = torch.zeros(4, dtype=torch.float64, device=adv.device), []
    for _ in range(args.epochs):
        perm = torch.randperm(B, device=adv.device)
        for k in range(args.minibatches):
            idx = perm[k * mb:(k + 1) * mb]
            o = flat["nobs"][idx]
            mu, log_std = model.actor(o), model.log_std
            with torch.no_grad():
                kl = kl_divergence(flat["mu"][idx], log_std_old, mu, log_std).mean().item()
            if args.schedule == "adaptive":
                if kl > 2.0 * args.desired_kl:
                    lr = max(1e-5, lr / 1.5)
                elif 0.0 < kl < 0.5 * args.desired_kl:
                    lr = min(1e-2, lr * 1.5)
                for g in opt.param_groups:
                    g["lr"] = lr
            ratio = torch.exp(log_prob(flat["actions"][idx], mu, log_std) - flat["logp"][idx])
            a_mb = adv[idx]
            policy_loss = -torch.min(ratio * a_mb,
                                     ratio.clamp(1 - args.clip, 1 + args.clip) * a_mb).mean()
            value_loss = (model.value(o) - ret[idx]).pow(2).mean()
            entropy = (log_std + 0.5 + 0.5 * LOG_2PI).sum()
            loss = policy_loss + args.value_coef * value_loss - args.entropy_coef * entropy
            opt.zero_grad(set_to_none=True)
            loss.backward()
            nn.utils.clip_grad_norm_(model.parameters(), args.max_grad_norm)
            opt.step()
            with torch.no_grad():
                clipped = ((ratio - 1).abs() > args.clip).float().mean()
                sums += torch.stack([policy_loss, value_loss, entropy, clipped]).double()
            kls.append(kl)
    m = (sums / len(kls)).tolist()
    return {"policy_loss": m[0], "value_loss": m[1], "entropy": m[2], "clip_fraction": m[3],
            "kl": sum(kls) / len(kls), "action_std": model.log_std.exp().mean().item()}, lr


def write_atomic(path, text):
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def write_csv(path, rows):
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
    write_atomic(path, buf.getvalue())


def plot(out, rows, target):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    pts = [(r["slot_steps"], r["mean_return"]) for r in rows if r["mean_return"] != ""]
    fig, ax = plt.subplots(figsize=(7, 4))
    if pts:
        ax.plot(*zip(*pts), label="mean return (newest >= 100 episodes)")
    if target is not None:
        ax.axhline(target, color="gray", ls="--", label=f"target {target}")
    ax.set_xlabel("slot-steps")
    ax.set_ylabel("return")
    ax.legend()
    fig.tight_layout()
    for ext in ("svg", "png"):
        fig.savefig(os.path.join(out, f"curve.tmp.{ext}"))
        os.replace(os.path.join(out, f"curve.tmp.{ext}"), os.path.join(out, f"curve.{ext}"))
    plt.close(fig)


def weighted_mean(updates, field):  # mean over the episodes of these updates
    n = sum(u["episodes"] for u in updates)
    return sum(u[field] for u in updates) / n if n else float("nan")


def blank(x, empty=""):  # NaN as an empty CSV cell (or None in JSON)
    return empty if math.isnan(x) else round(x, 6)


def main(argv=None):
    args = parse_args(argv)
    dev = torch.device(args.device)
    os.makedirs(args.out, exist_ok=True)
    torch.manual_seed(args.seed)
    if dev.type == "cuda" and args.tf32:
        torch.set_float32_matmul_precision("high")
    kw = {"threads": args.threads} if args.threads else {}
    env = bidex.make_vec(args.task, num_envs=args.num_envs, device=args.env_device or args.device,
                         seed=args.seed, **kw)
    N, T = args.num_envs, args.horizon
    D, A = env.single_observation_space.shape[0], env.single_action_space.shape[0]
    model = ActorCritic(D, A, args).to(dev)
    opt = torch.optim.Adam(model.parameters(), lr=args.lr)
    lr = args.lr
    as_t = lambda x: torch.as_tensor(x, device=dev)
    f32 = dict(dtype=torch.float32, device=dev)
    ro = {"nobs": torch.zeros(T, N, D, **f32), "actions": torch.zeros(T, N, A, **f32),
          "mu": torch.zeros(T, N, A, **f32), "logp": torch.zeros(T, N, **f32),
          "values": torch.zeros(T, N, **f32), "rewards": torch.zeros(T, N, **f32),
          "dones": torch.zeros(T, N, **f32)}
    obs, _ = env.reset()
    env_torch = isinstance(obs, torch.Tensor)  # the CUDA env hands out tensors, the CPU one numpy
    obs = as_t(obs).float()
    batch = N * T
    total_updates = -(-args.steps // batch)
    rows, updates, rates, reached = [], [], [], None
    start = time.monotonic()
    for update in range(1, total_updates + 1):
        t_iter = time.monotonic()
        ep = torch.zeros(4, dtype=torch.float64, device=dev)  # episodes, return, length, successes
        with torch.no_grad():
            ro["log_std"] = model.log_std.detach().clone()  # the rollout's Gaussian keeps its std
            std = ro["log_std"].exp()
            for t in range(T):
                if args.obs_norm:
                    model.obs_norm.update(obs)
                nobs = model.obs_norm(obs)
                mu = model.actor(nobs)
                a = mu + std * torch.randn_like(mu)  # stored unclipped; the env clips to [-1, 1]
                ro["nobs"][t], ro["actions"][t], ro["mu"][t] = nobs, a, mu
                ro["values"][t] = model.value(nobs)
                ro["logp"][t] = log_prob(a, mu, ro["log_std"])
                obs, rew, term, trunc, info = env.step(a if env_torch else a.cpu().numpy())
                obs, rew, trunc = as_t(obs).float(), as_t(rew).float(), as_t(trunc)
                ro["dones"][t] = (as_t(term) | trunc).float()
                if "final_obs" in info:  # time limits (not faults) bootstrap from the critic
                    boot = trunc & as_t(info["_final_obs"])
                    if "fault" in info:
                        boot &= ~as_t(info["fault"])
                    v_fin = model.value(model.obs_norm(as_t(info["final_obs"]).float()))
                    rew = rew + args.gamma * torch.where(boot, v_fin, torch.zeros_like(v_fin))
                ro["rewards"][t] = rew
                if "episode" in info:
                    m, e = as_t(info["_episode"]), info["episode"]
                    ep += torch.stack([(as_t(x).double() * m).sum()
                                       for x in (m, e["r"], e["l"], e["success"])])
            last_value = model.value(model.obs_norm(obs))
        stats, lr = ppo_update(model, opt, ro, last_value, args, lr)
        n_ep, r_sum, l_sum, s_sum = ep.tolist()
        rate = batch / (time.monotonic() - t_iter)
        rates.append(rate)
        wall = time.monotonic() - start
        updates.append({"episodes": n_ep, "r": r_sum, "l": l_sum, "s": s_sum})
        recent, n = [], 0  # newest whole updates holding >= 100 episodes
        for u in reversed(updates):
            recent.append(u)
            n += u["episodes"]
            if n >= 100:
                break
        mean_return = weighted_mean(recent, "r") if n >= 100 else float("nan")
        success = weighted_mean(recent, "s") if n >= 100 else float("nan")
        rows.append({"update": update, "slot_steps": update * batch, "wall_s": round(wall, 3),
                     "env_steps_per_s": round(rate, 1), "episodes": int(n_ep),
                     "return": blank(r_sum / n_ep if n_ep else float("nan")),
                     "length": blank(l_sum / n_ep if n_ep else float("nan")),
                     "mean_return": blank(mean_return), "success": blank(success), "lr": lr,
                     **{k: round(v, 6) for k, v in stats.items()}})
        if reached is None and args.target is not None and mean_return >= args.target:
            reached = {"update": update, "slot_steps": update * batch, "wall_s": round(wall, 3),
                       "mean_return": mean_return}
            print(f"target {args.target} reached at {update * batch:,} slot-steps, {wall:.0f} s",
                  flush=True)
        done = update == total_updates or (reached is not None and args.stop_at_target)
        if update % args.log_every == 0 or done:
            eta = (total_updates - update) * batch / max(update * batch / wall, 1e-9)
            print(f"update {update}/{total_updates}  {update * batch / 1e6:.2f}M slot-steps  "
                  f"{rate:,.0f} slot-steps/s  return(>=100 ep) {mean_return:.2f}  "
                  f"success {success:.2f}  lr {lr:.1e}  kl {stats['kl']:.4f}  "
                  f"std {stats['action_std']:.3f}  {wall:.0f}s  ETA {eta:.0f}s", flush=True)
            write_csv(os.path.join(args.out, "metrics.csv"), rows)
            if args.plot:
                plot(args.out, rows, args.target)
        if done:
            break
    last = updates[-10:]
    summary = {
        "task": args.task, "num_envs": N, "steps": rows[-1]["slot_steps"], "updates": len(rows),
        "wall_s": rows[-1]["wall_s"], "median_slot_steps_per_s": statistics.median(rates),
        "final_mean_return": blank(weighted_mean(last, "r"), None),
        "final_success": blank(weighted_mean(last, "s"), None),
        "final_episodes": int(sum(u["episodes"] for u in last)),
        "last_mean_return": blank(mean_return, None), "target": args.target,
        "target_reached_at": reached,
        "device": torch.cuda.get_device_name(dev) if dev.type == "cuda" else "cpu",
        "torch": torch.__version__, "command": " ".join([sys.executable] + sys.argv),
        "args": vars(args), "date": datetime.datetime.now(datetime.timezone.utc).isoformat(),
    }
    write_atomic(os.path.join(args.out, "summary.json"), json.dumps(summary, indent=2) + "\n")
    print(f"final mean return (last {len(last)} updates) {summary['final_mean_return']}  "
          f"median {summary['median_slot_steps_per_s']:,.0f} slot-steps/s  -> {args.out}")
    env.close()


if __name__ == "__main__":
    main()
