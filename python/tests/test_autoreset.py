"""Gymnasium's three autoreset modes, each against the SAME_STEP env of the same seed and
actions, on the CPU pack and on the GPU pack's code (Warp's CPU device, with the task whose
kernels the C++ tests compile) (python/README.md); the meta-RL task assignment of a goal suite."""
import gymnasium as gym
import numpy as np
import pytest

import bidex
from bidex import _bidex

AutoresetMode = gym.vector.AutoresetMode
GPU_PATH = pytest.param("warp-cpu", marks=pytest.mark.skipif(
    bool(_bidex.gpu_backend_missing()), reason="this build has no GPU backend"))


# values of two envs compared: bitwise on the CPU and on Warp's CPU device (the GPU's atomic sums
# make two CUDA envs agree only closely: bench/python_cuda_check.py sets a tolerance)
alike = np.array_equal


def actions(env, rng):
    return rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)


@pytest.mark.parametrize("device", ["cpu", GPU_PATH])
def test_next_step_hands_back_the_last_observation_then_resets_in_the_next_step(device):
    # One world, episodes of 6 steps, random actions (catches may also drop: terminations).
    # SAME_STEP ends and restarts a world in one step; NEXT_STEP returns the last observation
    # and restarts the world in the next step, which ignores its action and returns reward 0,
    # no flags and the new episode's first observation: the same values, one step later
    # fewer steps on Warp's CPU device (a step of its one world takes about 0.1 s there)
    task, steps, least = (("catch_underarm", 40, 5) if device == "cpu"
                          else ("catch_underarm_raise", 14, 2))
    kw = dict(seed=3, overrides={"episode_length": 6}, device=device)
    same = bidex.make_vec(task, 1, **kw)
    nxt = bidex.make_vec(task, 1, autoreset_mode="next_step", **kw)
    assert nxt.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert bidex.BidexVectorEnv.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    o1, _ = same.reset()
    o2, _ = nxt.reset()
    assert alike(o1, o2)
    rng = np.random.default_rng(2)
    ends = 0
    for t in range(steps):
        a = actions(same, rng)
        o1, r1, te1, tr1, i1 = same.step(a)
        o2, r2, te2, tr2, i2 = nxt.step(a)
        assert alike(r1, r2) and np.array_equal(te1, te2) and np.array_equal(tr1, tr2)
        assert "final_obs" not in i2
        if not (te1 | tr1)[0]:
            assert alike(o1, o2)
            continue
        ends += 1
        assert alike(o2[0], i1["final_obs"][0])     # the episode's last observation
        assert i2["_episode"][0] and alike(i2["episode"]["r"][0], i1["episode"]["r"][0])
        assert i2["episode"]["l"][0] == i1["episode"]["l"][0]
        o3, r3, te3, tr3, i3 = nxt.step(np.full_like(a, np.nan))  # ignored: no fault
        assert alike(o3[0], o1[0])                   # the new episode's first
        assert r3[0] == 0 and not te3[0] and not tr3[0] and not i3["fault"][0]
        assert "_episode" not in i3
    assert ends >= least


@pytest.mark.parametrize("device", ["cpu", GPU_PATH])
def test_disabled_holds_ended_worlds_until_a_masked_reset(device):
    task, steps, least = (("catch_abreast", 23, 12) if device == "cpu"
                          else ("catch_underarm_raise", 11, 8))
    kw = dict(seed=5, overrides={"episode_length": 5}, device=device)
    same = bidex.make_vec(task, 4, **kw)
    off = bidex.make_vec(task, 4, autoreset_mode=AutoresetMode.DISABLED, **kw)
    same.reset()
    off.reset()
    rng = np.random.default_rng(4)
    ends = 0
    for t in range(steps):
        a = actions(same, rng)
        o1, r1, te1, tr1, i1 = same.step(a)
        o2, r2, te2, tr2, i2 = off.step(a)
        done = te1 | tr1
        assert alike(r1, r2) and np.array_equal(te1, te2) and np.array_equal(tr1, tr2)
        assert "final_obs" not in i2
        if done.any():
            assert alike(o2[done], i1["final_obs"][done])
        assert alike(o2[~done], o1[~done])
        ends += done.sum()
        o3, info = off.reset(options={"reset_mask": done})
        assert info == {} and alike(o3, o1)   # every row as the autoreset's
    assert ends >= least
    # a world left ended holds its last observation, earns nothing and raises no flag
    for _ in range(5):
        o, *_ = off.step(actions(off, rng))
    held = o.copy()
    for _ in range(3):
        o, r, te, tr, info = off.step(actions(off, rng))
        assert np.array_equal(o, held) and np.all(r == 0) and not (te | tr).any()
    o, _ = off.reset(options={"reset_mask": np.array([True, False, False, False])})
    assert not np.array_equal(o[0], held[0]) and np.array_equal(o[1:], held[1:])


def test_autoreset_mode_errors_name_the_expected_and_the_actual_value():
    with pytest.raises(ValueError, match=r"autoreset_mode: expected one of .*got 'sometimes'"):
        bidex.make_vec("hand_over", 2, autoreset_mode="sometimes")
    env = bidex.make_vec("hand_over", 2)
    env.reset()
    with pytest.raises(ValueError, match=r"'reset_mask' expects the DISABLED .*got SAME_STEP"):
        env.reset(options={"reset_mask": np.ones(2, bool)})
    off = bidex.make_vec("hand_over", 2, autoreset_mode="disabled")
    with pytest.raises(RuntimeError, match="without a mask first"):
        off.reset(options={"reset_mask": np.ones(2, bool)})
    off.reset()
    with pytest.raises(ValueError, match=r"reset_mask'\]: expected a bool array of shape \(2,\), "
                                         r"got int64 \(3,\)"):
        off.reset(options={"reset_mask": np.ones(3, np.int64)})
    with pytest.raises(ValueError, match=r"seed: expected None with a reset_mask"):
        off.reset(seed=1, options={"reset_mask": np.ones(2, bool)})
    with pytest.raises(ValueError, match=r"options: expected none, or 'reset_mask'.*\['foo'\]"):
        off.reset(options={"foo": 1})
    with pytest.raises(ValueError, match=r"expected SAME_STEP for the multi-agent view"):
        bidex.make_marl("hand_over", 2, autoreset_mode="next_step")


def test_gymnasium_make_vec_passes_the_autoreset_mode():
    # a vector entry point takes its arguments as keywords (Gymnasium's rule)
    env = gym.make_vec("bidex/hand_over-v0", num_envs=2, autoreset_mode=AutoresetMode.NEXT_STEP)
    assert env.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP


# ---- meta-RL's tasks ---------------------------------------------------------------------

def test_a_goal_suite_lists_its_tasks_and_set_tasks_moves_a_world_to_another_goal():
    env = bidex.make_vec("ML1-raise-goals", 4, seed=1, threads=1)
    e = env.entries[0]
    assert len(e["goals"]) >= 2 and len(env.tasks) == len(e["goals"])
    assert [t["entry"] for t in env.tasks] == [0] * len(env.tasks)
    k = len(env.tasks)
    assert env.task_of_env.tolist() == [i % k for i in range(4)]  # slot i takes goal i % k
    twin = bidex.make_vec("ML1-raise-goals", 4, seed=1, threads=1)
    tasks = env.task_of_env.copy()
    tasks[0] = (tasks[0] + 1) % k  # world 0 to another goal, from its next episode
    env.set_tasks(tasks)
    twin.set_tasks(twin.task_of_env)  # the same tasks: both start their second episodes
    assert env.task_of_env.tolist() == tasks.tolist()
    env.reset()
    twin.reset()
    z = np.zeros(env.action_space.shape, np.float32)
    diff = np.zeros(4, bool)
    for _ in range(5):
        o1, r1, *_ = env.step(z)
        o2, r2, *_ = twin.step(z)
        assert np.array_equal(o1, o2)  # the goal is not in a meta observation
        diff |= r1 != r2
    assert diff.tolist() == [True, False, False, False]  # the reward sees world 0's new goal
    # a seeded reset builds a new pack: the tasks set before still hold there
    env.reset(seed=9)
    twin.reset(seed=9)
    diff[:] = False
    for _ in range(5):
        o1, r1, *_ = env.step(z)
        o2, r2, *_ = twin.step(z)
        assert np.array_equal(o1, o2)
        diff |= r1 != r2
    assert diff.tolist() == [True, False, False, False]
    ids = env.sample_tasks(7)
    assert ids.shape == (4,) and ids.min() >= 0 and ids.max() < k
    assert np.array_equal(ids, env.sample_tasks(np.random.default_rng(7)))
    assert np.array_equal(env.task_of_env, ids)


def test_set_tasks_keeps_each_world_in_its_own_entry():
    env = bidex.make_vec("ML4", 4, seed=0, threads=1)  # train split: three tasks, one goal each
    assert len(env.tasks) == len(env.entries) == 3
    assert env.task_of_env.tolist() == env.entry_of_env.tolist() == [0, 0, 1, 2]
    env.set_tasks(env.task_of_env)  # the tasks they have: allowed
    bad = env.task_of_env.copy()
    bad[0] = 2
    with pytest.raises(ValueError, match=r"set_tasks: world 0 runs entry catch_underarm \(tasks "
                                         r"0\.\.0\), got task 2 \(catch_abreast\)"):
        env.set_tasks(bad)
    with pytest.raises(ValueError, match=r"expected task indices in \[0, 3\), got 0\.\.9"):
        env.set_tasks(np.array([0, 0, 1, 9]))
    with pytest.raises(ValueError, match=r"expected an integer array of shape \(4,\)"):
        env.set_tasks([0.5, 1, 2, 3])
    assert env.sample_tasks(0).tolist() == [0, 0, 1, 2]  # one task an entry: nothing to draw
