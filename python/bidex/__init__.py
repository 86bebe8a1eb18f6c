"""bidex from Python: the twenty Bi-DexHands tasks and their suites as Gymnasium vector
environments over bidex's C++ core (python/README.md).

    import bidex
    env = bidex.make_vec("catch_abreast", num_envs=64, seed=0)
    obs, info = env.reset()
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

Also ``gymnasium.make_vec("bidex/<task>-v0", num_envs=...)`` for every task id, and
``bidex.make_marl(task, num_envs, agents="hand"|"finger"|FILE)``, the multi-agent view.
"""
import gymnasium as _gym

import json as _json

from ._bidex import paper_task_ids, suite_ids, task_ids
from . import _bidex
from .marl import BidexParallelEnv, make_marl
from .vector import BidexVectorEnv, Layout, make_vec

__all__ = ["BidexParallelEnv", "BidexVectorEnv", "Layout", "make_marl", "make_vec",
           "paper_task_ids", "suite_ids", "task_ids", "task_spec"]


def task_spec(task: str, agents: str = "hand") -> dict:
    """A task's spec as ``bidex info --task TASK --agents AGENTS --json`` prints it: identity,
    age, difficulty, episode length, the named observation and action slices, the split's agents
    (``obs_columns``, ``act_columns``) and the reward terms."""
    return _json.loads(_bidex.task_spec_json(task, agents))


def _register():
    for t in task_ids():
        env_id = f"bidex/{t}-v0"
        if env_id not in _gym.registry:
            _gym.register(env_id, vector_entry_point="bidex.vector:vector_entry_point",
                          kwargs={"task": t})


_register()
