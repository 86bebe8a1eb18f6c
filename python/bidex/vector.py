"""bidex's tasks and suites as Gymnasium vector environments (python/README.md).

One environment is one pack of the C++ core (taskpack::TaskPack), the same object that bidex's
own learners step: every world of it steps in one call, in the core's parallel loop, with the
GIL released. Worlds reset inside the step that ends their episode (Gymnasium's SAME_STEP
autoreset); ``infos["final_obs"]`` holds the observation each finished world ended on.
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


def _check_count(name: str, value, least: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < least:
        raise ValueError(f"{name}: expected an integer >= {least}, got {value!r}")
    return int(value)


class BidexVectorEnv(VectorEnv):
    """A batch of ``num_envs`` worlds of one bidex task or suite (``bidex.make_vec`` makes one).

    Observations are float32 ``(num_envs, obs_dim)`` arrays in [-5, 5]; actions float32
    ``(num_envs, act_dim)`` in [-1, 1] (the core clips them; a NaN faults and resets that world,
    reported in ``infos["fault"]``). ``step`` returns ``(obs, rewards, terminations,
    truncations, infos)`` with rewards float32, and ``infos`` holds, each with its ``_key`` mask:
      - ``final_obs``: the observation each world whose episode ended this step ended on;
      - ``episode``: ``{"r", "l", "success"}``, that episode's return, length and success;
      - ``success`` (the episode's success flag so far), ``fault`` and, for one task, ``terms``:
        ``{term name: (num_envs,) array}``, the reward's terms (unscaled).
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": ["rgb_array"]}

    def __init__(self, pack_factory, num_envs: int, seed: int, copy: bool, name: str,
                 render_mode: str | None = None, render_worlds=(0,), render_size=(320, 240)):
        super().__init__()
        self._factory = pack_factory
        self._seed = seed
        self._copy = copy
        self.name = name
        self._pack = pack_factory(seed)
        self._fresh = True  # a new pack has started its first episodes: reset() takes them
        p = self._pack
        self.num_envs = p.nslot
        if self.num_envs != num_envs:
            raise RuntimeError(f"bidex: a pack of {p.nslot} worlds for num_envs={num_envs}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode: expected None or 'rgb_array', got {render_mode!r}")
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
                "reward_terms": [t["name"] for t in spec["reward_terms"]]})
            self.entry_of_env[b:b + n] = g
        self.layout = self.entries[0]["layout"] if len(self.entries) == 1 else None
        self._ep_return = np.zeros(self.num_envs, np.float64)
        self._ep_length = np.zeros(self.num_envs, np.int64)
        self._needs_reset = True

    # -- Gymnasium API ----------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if options:
            raise ValueError(f"reset: options: expected none (the SAME_STEP autoreset resets "
                             f"finished worlds inside step), got keys {sorted(options)}")
        if seed is not None:
            seed = _check_count("reset: seed", seed, 0)
            # the core's streams start from the pack's seed: a seeded reset is a new pack (the
            # same as make_vec with that seed), unless this one is new and has that seed
            if not (self._fresh and seed == self._seed):
                self._pack = self._factory(seed)
                self._seed = seed
                self._fresh = True
        if not self._fresh:  # new episodes in every world (a new pack has begun its first)
            self._pack.reset()
        self._fresh = False
        self._ep_return[:] = 0
        self._ep_length[:] = 0
        self._needs_reset = False
        return self._out(self._pack.obs), {}

    def step(self, actions):
        if self._needs_reset:
            raise RuntimeError("step: call reset() first")
        a = np.asarray(actions)
        if not np.issubdtype(a.dtype, np.floating):
            raise TypeError(f"step: actions: expected a float array (float32), got dtype {a.dtype}")
        want = (self.num_envs, self.single_action_space.shape[0])
        if a.shape != want:
            raise ValueError(f"step: actions: expected shape {want}, got {a.shape}")
        self._pack.step(np.ascontiguousarray(a, dtype=np.float32))
        p = self._pack
        reward = self._out(p.reward)
        term = p.terminated.astype(bool)
        trunc = p.truncated.astype(bool)
        done = term | trunc
        self._ep_return += reward
        self._ep_length += 1
        success = p.success.astype(bool)
        fault = p.fault.astype(bool)
        everyone = np.ones(self.num_envs, bool)
        infos = {"success": success, "_success": everyone, "fault": fault, "_fault": everyone}
        if len(self.entries) == 1:
            t = p.terms(0)
            infos["terms"] = {n: t[:, k].copy() for k, n in enumerate(self.entries[0]["reward_terms"])}
            infos["_terms"] = everyone
        if done.any():
            infos["final_obs"] = np.where(done[:, None], p.final_obs, 0).astype(np.float32)
            infos["_final_obs"] = done
            infos["episode"] = {"r": np.where(done, self._ep_return, 0.0),
                                "l": np.where(done, self._ep_length, 0),
                                "success": success & done}
            infos["_episode"] = done
            self._ep_return[done] = 0
            self._ep_length[done] = 0
        return self._out(p.obs), reward, term, trunc, infos

    def render(self):
        """With render_mode "rgb_array": a tuple of (height, width, 3) uint8 pictures, one for
        each of ``render_worlds``, from a camera that frames the scene (the core's headless
        renderer, as ``bidex render`` uses); None otherwise."""
        if self.render_mode != "rgb_array":
            return None
        w, h = self.render_size
        return tuple(self._pack.render(k, w, h) for k in self.render_worlds)

    def close_extras(self, **kwargs):
        self._pack = None

    # -- bidex ------------------------------------------------------------------------------
    @property
    def seed_value(self) -> int:
        """The seed the worlds' streams started from (make_vec's, or the last reset's)."""
        return self._seed

    def set_goal_shifts(self, entry: int, envs, shifts):
        """Moves the goals of some worlds of one entry by ``shifts`` (m), ``(len(envs), k*3)``
        for a task of k goals, from each world's next reset (meta-RL's goal sampling)."""
        s = np.asarray(shifts, np.float64).reshape(-1)
        self._pack.set_goal_shifts(int(entry), [int(e) for e in envs], s.tolist())

    def _out(self, view):
        return np.array(view) if self._copy else view


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
             copy: bool = True, render_mode: str | None = None, render_worlds=(0,),
             render_size=(320, 240)) -> BidexVectorEnv:
    """``num_envs`` worlds of a task (``bidex.task_ids()``) or of a suite's split
    (``bidex.suite_ids()``: MT1 ... ML20; ``split`` "train" or "test"), as a Gymnasium
    VectorEnv.

    - ``overrides``: values of the task's YAML by key path, e.g. ``{"reward.goal_bonus": 0}``;
      an unknown key is a ValueError naming it.
    - ``threads``: the core's threads (0: all cores). Results do not depend on it.
    - ``copy``: return copies (default) or read-only views of the core's buffers, which the next
      step overwrites.
    - ``render_mode``: "rgb_array" for ``render()``, pictures of ``render_worlds`` at
      ``render_size`` (width, height).
    - ``device``: "cpu". (The GPU backend is not in the Python module yet.)
    """
    if device != "cpu":
        raise ValueError(f"device: expected 'cpu' (the Python module does not drive the GPU "
                         f"backend yet), got {device!r}")
    num_envs = _check_count("num_envs", num_envs)
    seed = _check_count("seed", seed, 0)
    threads = _check_count("threads", threads, 0)
    view = (render_mode, render_worlds, render_size)
    if not isinstance(task, str):
        raise ValueError(f"task: expected a task or suite id, got {task!r}")
    if task in _bidex.suite_ids():
        if overrides:
            raise ValueError(f"overrides: a suite ({task}) takes its tasks' YAMLs from "
                             f"configs/suites/{task}.yaml; expected none, got {overrides!r}")
        if split not in ("train", "test"):
            raise ValueError(f"split: expected 'train' or 'test', got {split!r}")
        factory = lambda s: _bidex.Pack.from_suite(task, split, num_envs, s, threads)
        return BidexVectorEnv(factory, num_envs, seed, copy, f"{task}/{split}", *view)
    if task not in _bidex.task_ids():
        raise ValueError(f"task: expected one of the task ids {', '.join(_bidex.task_ids())} "
                         f"or the suites {', '.join(_bidex.suite_ids())}, got {task!r}")
    if overrides is not None and not isinstance(overrides, dict):
        raise ValueError(f"overrides: expected a dict of YAML key paths to values, got "
                         f"{type(overrides).__name__}")
    values = dict(overrides or {})
    # the pack reads the task's YAML when built; a reset with a new seed builds it again
    factory = lambda s: _task_pack(task, values, num_envs, s, threads)
    return BidexVectorEnv(factory, num_envs, seed, copy, task, *view)


def _task_pack(task, overrides, num_envs, seed, threads):
    config = _task_config(task, overrides) if overrides else ""
    try:
        return _bidex.Pack.from_entries(task, "plain",
                                        [{"task": task, "slots": num_envs, "config": config}],
                                        seed, threads)
    finally:
        if config:
            os.unlink(config)


def vector_entry_point(task: str, num_envs: int = 1, **kwargs) -> BidexVectorEnv:
    """gymnasium.make_vec("bidex/<task>-v0", num_envs=...) lands here."""
    kwargs.pop("vectorization_mode", None)
    return make_vec(task, num_envs, **kwargs)
