"""A multi-agent view of a bidex vector environment, after PettingZoo's Parallel API, batched as
Isaac Lab's DirectMARLEnv is: every dict holds one ``(num_envs, ...)`` array per agent
(python/README.md). The agents are bidex's splits (``bidex train --agents``): ``hand`` (two),
``finger`` (six a hand) or a YAML file of agents.
"""
from __future__ import annotations

import json
import os

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode

from . import _bidex
from .vector import OBS_CLIP, BidexVectorEnv, _autoreset_mode, make_vec


class BidexParallelEnv:
    """``possible_agents``, ``agents``, ``observation_space(agent)`` and ``action_space(agent)``
    (the same object on every call), ``reset(seed, options) -> (obs, infos)`` and
    ``step(actions) -> (obs, rewards, terminations, truncations, infos)``, each a dict by agent of
    batched arrays. Every agent gets the task's reward and the worlds' end flags (the agents are
    one team, as in the original); ``state()`` is the full observation, what a centralised
    critic sees. ``infos[agent]`` holds the vector env's infos with ``final_obs`` cut to the
    agent's columns. Worlds reset inside the step that ends them, so agents never leave
    ``agents``."""

    def __init__(self, env: BidexVectorEnv, task: str, agents: str):
        self.env = env
        self.num_envs = env.num_envs
        split = json.loads(_bidex.task_spec_json(task, agents))["agents"]
        self.metadata = {"name": f"bidex_{task}", "autoreset_mode": env.metadata["autoreset_mode"],
                         "render_modes": []}
        self.possible_agents = [a["name"] for a in split]
        self.agents = list(self.possible_agents)
        self.split = {a["name"]: a for a in split}
        self._obs_cols = {a["name"]: np.asarray(a["obs_columns"], np.int64) for a in split}
        self._act_cols = {a["name"]: np.asarray(a["act_columns"], np.int64) for a in split}
        n = self.num_envs
        self._obs_spaces = {k: gymnasium.spaces.Box(-OBS_CLIP, OBS_CLIP, (n, len(c)), np.float32)
                            for k, c in self._obs_cols.items()}
        self._act_spaces = {k: gymnasium.spaces.Box(-1.0, 1.0, (n, len(c)), np.float32)
                            for k, c in self._act_cols.items()}
        self.state_space = env.observation_space
        self._act_dim = env.single_action_space.shape[0]
        self._state = None

    def observation_space(self, agent: str):
        return self._obs_spaces[self._known(agent)]

    def action_space(self, agent: str):
        return self._act_spaces[self._known(agent)]

    def state(self):
        """The full observation of every world, ``(num_envs, obs_dim)``."""
        if self._state is None:
            raise RuntimeError("state: call reset() first")
        return self._state

    def reset(self, seed: int | None = None, options: dict | None = None):
        full, _ = self.env.reset(seed=seed, options=options)
        self._state = full
        return self._split(full), {a: {} for a in self.agents}

    def step(self, actions: dict):
        if not isinstance(actions, dict):
            raise TypeError(f"step: actions: expected a dict of agent -> array, got "
                            f"{type(actions).__name__}")
        missing = [a for a in self.agents if a not in actions]
        extra = [a for a in actions if a not in self._act_cols]
        if missing or extra:
            raise ValueError(f"step: actions: expected one array for each agent of "
                             f"{self.agents}, got keys {list(actions)}")
        torch = self.env._core.torch  # a GPU env takes torch tensors
        if torch is None:
            full = np.zeros((self.num_envs, self._act_dim), np.float32)
        else:
            full = torch.zeros((self.num_envs, self._act_dim), dtype=torch.float32,
                               device=self.env.device)
        for a, cols in self._act_cols.items():
            x = actions[a]
            if torch is None or not isinstance(x, torch.Tensor):
                x = np.asarray(x)
                if not np.issubdtype(x.dtype, np.floating):
                    raise TypeError(f"step: actions['{a}']: expected a float array (float32), "
                                    f"got dtype {x.dtype}")
                if torch is not None:
                    x = torch.from_numpy(x.astype(np.float32))
            elif not x.dtype.is_floating_point:
                raise TypeError(f"step: actions['{a}']: expected a float tensor (float32), got "
                                f"dtype {x.dtype}")
            want = (self.num_envs, len(cols))
            if tuple(x.shape) != want:
                raise ValueError(f"step: actions['{a}']: expected shape {want}, got "
                                 f"{tuple(x.shape)}")
            full[:, cols] = x if torch is None else x.to(full.device, torch.float32)
        obs, reward, term, trunc, info = self.env.step(full)
        self._state = obs
        infos = {}
        for a, cols in self._obs_cols.items():
            mine = dict(info)
            if "final_obs" in info:
                mine["final_obs"] = info["final_obs"][:, cols]
            infos[a] = mine
        same = lambda x: {a: x for a in self.agents}
        return self._split(obs), same(reward), same(term), same(trunc), infos

    def close(self):
        self.env.close()

    def _split(self, full):
        torch = self.env._core.torch
        if torch is not None:  # the columns as index tensors on the env's device
            return {a: full[:, torch.as_tensor(c, device=full.device)]
                    for a, c in self._obs_cols.items()}
        return {a: full[:, c] for a, c in self._obs_cols.items()}

    def _known(self, agent):
        if agent not in self._obs_spaces:
            raise KeyError(f"agent: expected one of {self.possible_agents}, got {agent!r}")
        return agent


def make_marl(task: str, num_envs: int = 1, *, agents: str = "hand", **kwargs) -> BidexParallelEnv:
    """``num_envs`` worlds of a task, seen by the agents of a split: ``hand`` (right, left),
    ``finger`` (six a hand: palm, ff, mf, rf, lf, th) or the path of a YAML file of agents (the
    format of ``bidex train --agents FILE``, marl/README.md). Other keywords as ``make_vec``."""
    if task not in _bidex.task_ids():
        raise ValueError(f"task: expected one of the task ids {', '.join(_bidex.task_ids())}, "
                         f"got {task!r} (suites have no multi-agent view)")
    if not isinstance(agents, str) or (agents not in ("hand", "finger")
                                        and not os.path.isfile(agents)):
        raise ValueError(f"agents: expected 'hand', 'finger' or the path of a YAML file of "
                         f"agents, got {agents!r}")
    mode = kwargs.get("autoreset_mode", AutoresetMode.SAME_STEP)
    if _autoreset_mode(mode) != AutoresetMode.SAME_STEP:
        raise ValueError(f"autoreset_mode: expected SAME_STEP for the multi-agent view (its agents "
                         f"never leave: worlds reset within the step), got {mode!r}")
    _bidex.task_spec_json(task, agents)  # a bad split fails before the worlds are built
    return BidexParallelEnv(make_vec(task, num_envs, **kwargs), task, agents)
