"""bidex's tasks and suites as Gymnasium vector environments (python/README.md).

One environment is one pack of the C++ core, the same object that bidex's own learners step:
taskpack::TaskPack on the CPU (every world in one call of the core's parallel loop, the GIL
released; numpy arrays) or taskpack::WarpPack on the GPU (MuJoCo Warp; torch tensors over the
pack's own device rows). By default worlds reset inside the step that ends their episode
(Gymnasium's SAME_STEP autoreset) and ``infos["final_obs"]`` holds the observation each finished
world ended on; NEXT_STEP and DISABLED are options.
"""
from __future__ import annotations

import json
import numbers
import os
import tempfile
from dataclasses import dataclass, field

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from . import _bidex

OBS_CLIP = _bidex.OBS_CLIP  # the core clips every observation to [-OBS_CLIP, OBS_CLIP]


@dataclass(frozen=True)
class Layout:
    """Named slices of a task's observation and action vectors, as ``bidex info`` prints them."""

    obs: dict = field(default_factory=dict)   # name -> slice
    act: dict = field(default_factory=dict)
    goal: tuple = ()                          # the observation slices that describe the goal

    @staticmethod
    def of(spec: dict) -> "Layout":
        sl = lambda rows: {r["name"]: slice(r["start"], r["start"] + r["size"]) for r in rows}
        return Layout(sl(spec["obs"]), sl(spec["act"]),
                      tuple(r["name"] for r in spec["obs"] if r["goal"]))


def _nested(overrides: dict) -> dict:
    """{"reward.goal_bonus": 0} and {"reward": {"goal_bonus": 0}} alike, as nested dicts."""
    out: dict = {}
    for key, value in overrides.items():
        if not isinstance(key, str) or not key:
            raise ValueError(f"overrides: expected keys that are YAML key paths such as "
                             f"'reward.goal_bonus', got {key!r}")
        node = out
        parts = key.split(".")
        for p in parts[:-1]:
            node = node.setdefault(p, {})
            if not isinstance(node, dict):
                raise ValueError(f"overrides: '{key}' goes below '{p}', which is set to a value")
        if isinstance(value, dict):
            node.setdefault(parts[-1], {}).update(_nested(value))
        else:
            node[parts[-1]] = value
    return out


_MODES = {m.value.lower(): m for m in AutoresetMode}
_MODES.update({m.name.lower(): m for m in AutoresetMode})


def _autoreset_mode(mode) -> AutoresetMode:
    """AutoresetMode, or its name or value ("same_step", "SameStep", ...)"""
    if isinstance(mode, AutoresetMode):
        return mode
    if isinstance(mode, str) and mode.lower() in _MODES:
        return _MODES[mode.lower()]
    raise ValueError(f"autoreset_mode: expected one of {', '.join(m.name for m in AutoresetMode)} "
                     f"(gymnasium.vector.AutoresetMode, or its name), got {mode!r}")


def _check_count(name: str, value, least: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < least:
        raise ValueError(f"{name}: expected an integer >= {least}, got {value!r}")
    return int(value)


class _HostCore:
    """A CPU pack's rows as numpy arrays (views of the core's host vectors)."""

    device = "cpu"
    torch = None  # numpy arrays, as on Warp's CPU device; a CUDA pack's core holds torch

    def __init__(self, pack):
        self.pack = pack
        self.single = pack.ngroups == 1

    def step(self, a):
        self.pack.step(np.ascontiguousarray(a, dtype=np.float32))

    def rows(self):
        p = self.pack
        return (p.obs, p.reward, p.terminated.astype(bool), p.truncated.astype(bool),
                p.success.astype(bool), p.fault.astype(bool))

    def final_obs(self, done):
        return np.where(done[:, None], self.pack.final_obs, 0).astype(np.float32)

    def terms(self):
        return self.pack.terms(0)


class _DeviceCore:
    """A GPU pack's rows in place: torch tensors on a CUDA device (zero-copy, DLPack), or numpy
    arrays on Warp's CPU device (device "warp-cpu": the GPU path's code, for tests)."""

    def __init__(self, pack):
        self.pack = pack
        self.device = pack.device
        self.single = pack.ngroups == 1
        if pack.on_gpu:
            try:
                import torch
            except ImportError as e:
                raise ImportError(f"device={self.device!r}: the GPU pack's rows are handed over as "
                                  f"torch tensors; install PyTorch with CUDA") from e
            self.torch = torch
            self.wrap = torch.from_dlpack
            self.tdev = torch.device(self.device)
        else:
            self.torch = None
            self.wrap = np.from_dlpack
        v = lambda name: self.wrap(pack.view(name))
        self.actions, self.obs, self.final_rows, self.reward = (
            v("actions"), v("obs"), v("final_obs"), v("reward"))
        flags = lambda name: [self.wrap(pack.entry_flags(g, name)) for g in range(pack.ngroups)]
        self.flags = {n: flags(n) for n in ("terminated", "truncated", "success", "faulted")}
        self.terms_view = self.wrap(pack.entry_terms(0)) if self.single else None

    def _cat(self, parts):
        if self.torch is None:
            return np.concatenate(parts).astype(bool)
        return (parts[0] if len(parts) == 1 else self.torch.cat(parts)).bool()

    def step(self, a):
        if self.torch is None:
            self.actions[...] = np.asarray(a, np.float32)
            self.pack.step_device()
            return
        t = self.torch
        if isinstance(a, np.ndarray):
            a = t.from_numpy(np.ascontiguousarray(a, np.float32))
        if not isinstance(a, t.Tensor):
            raise TypeError(f"step: actions: expected a torch tensor on {self.device} (or a "
                            f"numpy array), got {type(a).__name__}")
        if a.dtype != t.float32:
            raise TypeError(f"step: actions: expected dtype torch.float32, got {a.dtype}")
        if a.device.type == "cuda" and a.device.index != self.tdev.index and \
                self.tdev.index is not None:
            raise ValueError(f"step: actions: expected a tensor on {self.device}, got one on "
                             f"{a.device}")
        self.actions.copy_(a)  # on the consumer's (torch's current) stream
        # the pack's streams read the actions only once the consumer's writes have finished;
        # step_device returns after the pack's streams have written every row
        t.cuda.current_stream(self.actions.device).synchronize()
        self.pack.step_device()

    def rows(self):
        f = self.flags
        return (self.obs, self.reward, self._cat(f["terminated"]), self._cat(f["truncated"]),
                self._cat(f["success"]), self._cat(f["faulted"]))

    def final_obs(self, done):
        if self.torch is None:
            return np.where(done[:, None], self.final_rows, 0).astype(np.float32)
        return self.torch.where(done[:, None], self.final_rows, 0.0)

    def terms(self):
        return self.terms_view


class BidexVectorEnv(VectorEnv):
    """A batch of ``num_envs`` worlds of one bidex task or suite (``bidex.make_vec`` makes one).

    Observations are float32 ``(num_envs, obs_dim)`` arrays in [-5, 5]; actions float32
    ``(num_envs, act_dim)`` in [-1, 1] (the core clips them; a NaN faults and resets that world,
    reported in ``infos["fault"]``). On the CPU they are numpy arrays; on a GPU torch tensors on
    that device. ``step`` returns ``(obs, rewards, terminations, truncations, infos)`` with
    rewards float32, and ``infos`` holds, each with its ``_key`` mask:
      - ``final_obs`` (SAME_STEP): the observation each world whose episode ended this step ended
        on;
      - ``episode``: ``{"r", "l", "success"}``, that episode's return, length and success;
      - ``success`` (the episode's success flag so far), ``fault`` and, for one task, ``terms``:
        ``{term name: (num_envs,) array}``, the reward's terms (unscaled).
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": ["rgb_array"]}

    def __init__(self, pack_factory, num_envs: int, seed: int, copy, name: str,
                 render_mode: str | None = None, render_worlds=(0,), render_size=(320, 240),
                 autoreset_mode=AutoresetMode.SAME_STEP):
        super().__init__()
        self._factory = pack_factory
        self._seed = seed
        self.name = name
        self.autoreset_mode = _autoreset_mode(autoreset_mode)
        self.metadata = dict(type(self).metadata, autoreset_mode=self.autoreset_mode)
        self._build(seed)
        p = self._pack
        self.device = p.device
        # copies (numpy's default) on the CPU; on a GPU the pack's own rows, overwritten by the
        # next step, unless copy=True
        self._copy = (p.device == "cpu") if copy is None else bool(copy)
        self.num_envs = p.nslot
        if self.num_envs != num_envs:
            raise RuntimeError(f"bidex: a pack of {p.nslot} worlds for num_envs={num_envs}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode: expected None or 'rgb_array', got {render_mode!r}")
        if render_mode and p.device != "cpu":
            raise ValueError(f"render_mode: expected None on device {p.device!r} (pictures come "
                             f"from the CPU pack's worlds), got {render_mode!r}")
        self.render_mode = render_mode
        self.render_worlds = [int(w) for w in render_worlds]
        bad = [w for w in self.render_worlds if not 0 <= w < self.num_envs]
        if bad or not self.render_worlds:
            raise ValueError(f"render_worlds: expected worlds in [0, {self.num_envs}), got "
                             f"{list(render_worlds)}")
        w, h = render_size
        if not (1 <= int(w) <= 4096 and 1 <= int(h) <= 4096):
            raise ValueError(f"render_size: expected (width, height) in [1, 4096], got "
                             f"{tuple(render_size)}")
        self.render_size = (int(w), int(h))
        self.single_observation_space = gymnasium.spaces.Box(
            -OBS_CLIP, OBS_CLIP, (p.obs_dim,), np.float32)
        self.single_action_space = gymnasium.spaces.Box(-1.0, 1.0, (p.act_dim,), np.float32)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        # the pack's entries: one for a task, one per task for a suite
        self.entries = []
        self.entry_of_env = np.zeros(self.num_envs, np.int32)
        for g in range(p.ngroups):
            b, n = p.group_begin(g), p.group_slots(g)
            spec = json.loads(_bidex.task_spec_json(p.group_task(g), "hand"))
            self.entries.append({
                "label": p.group_label(g), "task": spec["id"], "first_env": b, "num_envs": n,
                "reward_scale": p.group_reward_scale(g), "one_hot_column": p.hot_column(g),
                "obs_keep": np.asarray(p.group_obs_keep(g), bool), "layout": Layout.of(spec),
                "reward_terms": [t["name"] for t in spec["reward_terms"]],
                "goals": [tuple(x) for x in p.group_goals(g)]})
            self.entry_of_env[b:b + n] = g
        self.layout = self.entries[0]["layout"] if len(self.entries) == 1 else None
        # meta-RL's tasks: an entry, or with a goal distribution each of its goals
        self.tasks = []
        for g, e in enumerate(self.entries):
            for k, goal in enumerate(e["goals"] or [None]):
                label = e["label"] if goal is None else f"{e['label']}/goal{k}"
                self.tasks.append({"name": label, "entry": g, "goal": goal})
        self.task_of_env = np.asarray(p.slot_tasks(), np.int32)
        self._ep_return = np.zeros(self.num_envs, np.float64)
        self._ep_length = np.zeros(self.num_envs, np.int64)
        self._held = np.zeros(self.num_envs, bool)  # NEXT_STEP: ended last step, reset in this one
        self._tasks_given = False
        self._needs_reset = True

    def _build(self, seed):
        self._pack = self._factory(seed)
        self._core = _HostCore(self._pack) if self._pack.device == "cpu" else _DeviceCore(self._pack)
        if self.autoreset_mode != AutoresetMode.SAME_STEP:
            self._pack.set_autoreset(False)
        self._fresh = True  # a new pack has started its first episodes: reset() takes them

    # -- Gymnasium API ----------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        options = dict(options or {})
        mask = options.pop("reset_mask", None)
        if options:
            raise ValueError(f"reset: options: expected none, or 'reset_mask' with the DISABLED "
                             f"autoreset mode, got keys {sorted(options)}")
        if mask is not None:
            return self._reset_some(mask, seed)
        if seed is not None:
            seed = _check_count("reset: seed", seed, 0)
            # the core's streams start from the pack's seed: a seeded reset is a new pack (the
            # same as make_vec with that seed), unless this one is new and has that seed
            if not (self._fresh and seed == self._seed):
                self._build(seed)
                self._seed = seed
                if self._tasks_given:  # the new pack's worlds take the tasks set before
                    self._give_tasks(self.task_of_env)
        if not self._fresh:  # new episodes in every world (a new pack has begun its first)
            self._pack.reset()
        self._fresh = False
        self._ep_return[:] = 0
        self._ep_length[:] = 0
        self._held[:] = False
        self._needs_reset = False
        return self._out(self._core.rows()[0]), {}

    def _reset_some(self, mask, seed):
        if self.autoreset_mode != AutoresetMode.DISABLED:
            raise ValueError(f"reset: options: 'reset_mask' expects the DISABLED autoreset mode, "
                             f"got {self.autoreset_mode.name}")
        if seed is not None:
            raise ValueError("reset: seed: expected None with a reset_mask (a seed restarts "
                             "every world's streams: reset(seed=...) without a mask)")
        if self._needs_reset:
            raise RuntimeError("reset: call reset() without a mask first")
        m = np.asarray(mask)
        if m.dtype != bool or m.shape != (self.num_envs,):
            raise ValueError(f"reset: options['reset_mask']: expected a bool array of shape "
                             f"({self.num_envs},), got {m.dtype} {m.shape}")
        self._pack.reset_slots(m.astype(np.uint8))
        self._ep_return[m] = 0
        self._ep_length[m] = 0
        return self._out(self._core.rows()[0]), {}

    def step(self, actions):
        if self._needs_reset:
            raise RuntimeError("step: call reset() first")
        core = self._core
        if core.torch is None:
            a = np.asarray(actions)
            if not np.issubdtype(a.dtype, np.floating):
                raise TypeError(f"step: actions: expected a float array (float32), got dtype "
                                f"{a.dtype}")
        else:
            a = actions
        want = (self.num_envs, self.single_action_space.shape[0])
        if tuple(a.shape) != want:
            raise ValueError(f"step: actions: expected shape {want}, got {tuple(a.shape)}")
        core.step(a)
        held = self._held
        if held.any():  # NEXT_STEP: the worlds that ended last step start their next episode
            self._pack.reset_slots(held.astype(np.uint8))
        obs, reward, term, trunc, success, fault = core.rows()
        done = term | trunc
        if core.torch is None:
            host_reward, host_done, host_success = reward, done, success
        else:  # the per-episode records on the host (one small copy each)
            host_reward = reward.double().cpu().numpy()
            host_done, host_success = done.cpu().numpy(), success.cpu().numpy()
        self._ep_return += host_reward
        self._ep_length += ~held
        reward = self._out(reward)
        everyone = self._everyone(obs)
        infos = {"success": success, "_success": everyone, "fault": fault, "_fault": everyone}
        if core.single:
            t = core.terms()
            infos["terms"] = {n: self._own(t[:, k])
                              for k, n in enumerate(self.entries[0]["reward_terms"])}
            infos["_terms"] = everyone
        if host_done.any():
            if self.autoreset_mode == AutoresetMode.SAME_STEP:
                infos["final_obs"] = core.final_obs(done)
                infos["_final_obs"] = done
            ended = host_done
            infos["episode"] = {"r": np.where(ended, self._ep_return, 0.0),
                                "l": np.where(ended, self._ep_length, 0),
                                "success": host_success & ended}
            infos["_episode"] = ended
            self._ep_return[ended] = 0
            self._ep_length[ended] = 0
        if self.autoreset_mode == AutoresetMode.NEXT_STEP:
            self._held = np.asarray(host_done, bool).copy()
        return self._out(obs), reward, term, trunc, infos

    def render(self):
        """With render_mode "rgb_array": a tuple of (height, width, 3) uint8 pictures, one for
        each of ``render_worlds``, from a camera that frames the scene (the core's headless
        renderer, as ``bidex render`` uses); None otherwise."""
        if self.render_mode != "rgb_array":
            return None
        w, h = self.render_size
        return tuple(self._pack.render(k, w, h) for k in self.render_worlds)

    def close_extras(self, **kwargs):
        self._pack = self._core = None

    # -- bidex ------------------------------------------------------------------------------
    @property
    def seed_value(self) -> int:
        """The seed the worlds' streams started from (make_vec's, or the last reset's)."""
        return self._seed

    def set_goal_shifts(self, entry: int, envs, shifts):
        """Moves the goals of some worlds of one entry by ``shifts`` (m), ``(len(envs), k*3)``
        for a task of k goals, from each world's next reset (meta-RL's goal sampling). A reset
        with a new seed builds a new pack, which starts from the suite's goals again (use
        ``set_tasks`` for assignments that a seeded reset keeps)."""
        s = np.asarray(shifts, np.float64).reshape(-1)
        self._pack.set_goal_shifts(int(entry), [int(e) for e in envs], s.tolist())
        self._fresh = False  # the next reset() starts new episodes, which take them

    def set_tasks(self, tasks):
        """Gives each world a meta-RL task (an index into ``env.tasks``), from its next episode:
        a world takes a task of its own entry (its scene), i.e. one of the entry's goals in a
        goal-distribution suite (ML1-goals). ``env.task_of_env`` then holds them."""
        ids = np.asarray(tasks)
        if ids.shape != (self.num_envs,) or not np.issubdtype(ids.dtype, np.integer):
            raise ValueError(f"set_tasks: expected an integer array of shape ({self.num_envs},), "
                             f"got {ids.dtype} {ids.shape}")
        if ids.min() < 0 or ids.max() >= len(self.tasks):
            raise ValueError(f"set_tasks: expected task indices in [0, {len(self.tasks)}), got "
                             f"{ids.min()}..{ids.max()}")
        entry = np.array([t["entry"] for t in self.tasks])[ids]
        wrong = np.nonzero(entry != self.entry_of_env)[0]
        if wrong.size:
            w = int(wrong[0])
            own = [k for k, t in enumerate(self.tasks) if t["entry"] == self.entry_of_env[w]]
            raise ValueError(f"set_tasks: world {w} runs entry {self.entries[self.entry_of_env[w]]['label']}"
                             f" (tasks {own[0]}..{own[-1]}), got task {int(ids[w])} "
                             f"({self.tasks[int(ids[w])]['name']})")
        self._give_tasks(ids)
        self.task_of_env = ids.astype(np.int32)
        self._tasks_given = True  # a seeded reset's new pack takes them too

    def _give_tasks(self, ids):
        for g, e in enumerate(self.entries):
            if not e["goals"]:
                continue
            envs = np.nonzero(self.entry_of_env == g)[0]
            local = envs - e["first_env"]
            shifts = [self.tasks[int(ids[w])]["goal"] for w in envs]
            self._pack.set_goal_shifts(g, local.tolist(), np.ravel(shifts).tolist())
        self._fresh = False  # the next reset() starts new episodes, which take them

    def sample_tasks(self, rng=None):
        """Draws each world's task uniformly among its entry's tasks (``rng``: a
        numpy Generator or a seed), gives them with ``set_tasks`` and returns them."""
        rng = np.random.default_rng(rng)
        first = {}
        for k, t in enumerate(self.tasks):
            first.setdefault(t["entry"], []).append(k)
        ids = np.array([rng.choice(first[int(g)]) for g in self.entry_of_env], np.int64)
        self.set_tasks(ids)
        return ids

    def _everyone(self, like):
        t = self._core.torch
        if t is None:
            return np.ones(self.num_envs, bool)
        return t.ones(self.num_envs, dtype=t.bool, device=like.device)

    def _own(self, view):
        """A copy of a view of the core's buffers"""
        return np.array(view) if self._core.torch is None else view.clone()

    def _out(self, view):
        return self._own(view) if self._copy else view


def _task_config(task: str, overrides: dict) -> str:
    """A temporary task YAML: the task's default with `overrides` over it (the caller removes it)."""
    body = {"extends": _bidex.default_task_config(task)}
    body.update(_nested(overrides))
    fd, path = tempfile.mkstemp(prefix=f"bidex-{task}-", suffix=".yaml")
    with os.fdopen(fd, "w") as f:
        json.dump(body, f)  # JSON is YAML
    return path


def make_vec(task: str, num_envs: int = 1, *, device: str = "cpu", seed: int = 0,
             overrides: dict | None = None, split: str = "train", threads: int = 0,
             copy: bool | None = None, autoreset_mode=AutoresetMode.SAME_STEP,
             render_mode: str | None = None, render_worlds=(0,),
             render_size=(320, 240)) -> BidexVectorEnv:
    """``num_envs`` worlds of a task (``bidex.task_ids()``) or of a suite's split
    (``bidex.suite_ids()``: MT1 ... ML20; ``split`` "train" or "test"), as a Gymnasium
    VectorEnv.

    - ``device``: "cpu" (the core's CPU pack; numpy arrays), "cuda" or "cuda:N" (the GPU pack on
      MuJoCo Warp; torch tensors on that device, over the pack's own rows), or "warp-cpu" (the
      GPU pack's code on Warp's CPU device, numpy arrays: tests).
    - ``overrides``: values of the task's YAML by key path, e.g. ``{"reward.goal_bonus": 0}``;
      an unknown key is a ValueError naming it.
    - ``threads``: the core's threads on the CPU (0: all cores). Results do not depend on it.
    - ``copy``: return copies or the core's own buffers, which the next step overwrites
      (read-only numpy views on the CPU). Default: copies on the CPU, the buffers on a GPU.
    - ``autoreset_mode``: ``gymnasium.vector.AutoresetMode`` (or its name): SAME_STEP (default),
      NEXT_STEP, or DISABLED with ``reset(options={"reset_mask": mask})``.
    - ``render_mode``: "rgb_array" for ``render()``, pictures of ``render_worlds`` at
      ``render_size`` (width, height), on the CPU.
    """
    if not isinstance(device, str) or not (device in ("cpu", "cuda", "warp-cpu") or (
            device.startswith("cuda:") and device[5:].isdigit())):
        raise ValueError(f"device: expected 'cpu', 'cuda', 'cuda:N' or 'warp-cpu', got {device!r}")
    if device != "cpu" and _bidex.gpu_backend_missing():
        raise RuntimeError(f"device={device!r}: {_bidex.gpu_backend_missing()}")
    num_envs = _check_count("num_envs", num_envs)
    seed = _check_count("seed", seed, 0)
    threads = _check_count("threads", threads, 0)
    view = (render_mode, render_worlds, render_size, autoreset_mode)
    if not isinstance(task, str):
        raise ValueError(f"task: expected a task or suite id, got {task!r}")
    if task in _bidex.suite_ids():
        if overrides:
            raise ValueError(f"overrides: a suite ({task}) takes its tasks' YAMLs from "
                             f"configs/suites/{task}.yaml; expected none, got {overrides!r}")
        if split not in ("train", "test"):
            raise ValueError(f"split: expected 'train' or 'test', got {split!r}")
        factory = lambda s: _bidex.Pack.from_suite(task, split, num_envs, s, threads, device)
        return BidexVectorEnv(factory, num_envs, seed, copy, f"{task}/{split}", *view)
    if task not in _bidex.task_ids():
        raise ValueError(f"task: expected one of the task ids {', '.join(_bidex.task_ids())} "
                         f"or the suites {', '.join(_bidex.suite_ids())}, got {task!r}")
    if overrides is not None and not isinstance(overrides, dict):
        raise ValueError(f"overrides: expected a dict of YAML key paths to values, got "
                         f"{type(overrides).__name__}")
    values = dict(overrides or {})
    # the pack reads the task's YAML when built; a reset with a new seed builds it again
    factory = lambda s: _task_pack(task, values, num_envs, s, threads, device)
    return BidexVectorEnv(factory, num_envs, seed, copy, task, *view)


def _task_pack(task, overrides, num_envs, seed, threads, device):
    config = _task_config(task, overrides) if overrides else ""
    try:
        return _bidex.Pack.from_entries(task, "plain",
                                        [{"task": task, "slots": num_envs, "config": config}],
                                        seed, threads, device)
    finally:
        if config:
            os.unlink(config)


def vector_entry_point(task: str, num_envs: int = 1, **kwargs) -> BidexVectorEnv:
    """gymnasium.make_vec("bidex/<task>-v0", num_envs=...) lands here."""
    kwargs.pop("vectorization_mode", None)
    return make_vec(task, num_envs, **kwargs)
