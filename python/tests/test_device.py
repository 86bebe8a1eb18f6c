"""The GPU pack from Python (device "cuda"), run here on Warp's CPU device (device "warp-cpu"):
the same module code, the pack's own rows handed over through DLPack (numpy here, torch
tensors on a GPU), the autoreset's final observations, faults and errors. The task and physics
are those of the C++ tests on Warp's CPU device (tests/taskpack/warp_pack_test.cc), whose
compiled kernels Warp caches."""
import numpy as np
import pytest

import bidex
from bidex import _bidex

pytestmark = pytest.mark.skipif(bool(_bidex.gpu_backend_missing()),
                                reason="this build has no GPU backend")

TASK = "catch_underarm_raise"


def make(n=3, **kw):
    return bidex.make_vec(TASK, n, device="warp-cpu", **kw)


def test_the_gpu_pack_hands_over_its_own_rows_with_the_cpu_packs_shapes():
    env = make(seed=2)
    cpu = bidex.make_vec(TASK, 3, seed=2, threads=1)
    assert env.device == "warp-cpu" and cpu.device == "cpu"
    assert env.single_observation_space == cpu.single_observation_space
    assert env.single_action_space == cpu.single_action_space
    obs, info = env.reset()
    assert isinstance(obs, np.ndarray) and obs.dtype == np.float32 and obs.shape == (3, 422)
    assert info == {}
    first = obs.copy()
    o, r, te, tr, info = env.step(np.zeros((3, 52), np.float32))
    assert o is obs or np.shares_memory(o, obs)  # no copy: the pack's rows, overwritten
    assert not np.array_equal(o, first)
    assert r.dtype == np.float32 and te.dtype == bool and tr.dtype == bool
    names = [t["name"] for t in bidex.task_spec(TASK)["reward_terms"]]
    assert list(info["terms"]) == names
    total = sum(info["terms"][n].astype(np.float64) for n in names)
    assert np.allclose(total, r, rtol=1e-5, atol=1e-6)
    copied = make(seed=2, copy=True)
    o2, _ = copied.reset()
    assert not np.shares_memory(o2, copied._core.obs)


def test_the_gpu_pack_resets_within_the_step_and_hands_back_the_last_observation():
    env = make(seed=1, overrides={"episode_length": 4})
    twin = make(seed=1, overrides={"episode_length": 6})  # the same worlds, longer episodes
    env.reset()
    twin.reset()
    z = np.zeros((3, 52), np.float32)
    for t in range(1, 5):
        o1, r1, te1, tr1, i1 = env.step(z)
        o2, *_ = twin.step(z)
        if t < 4:
            assert "final_obs" not in i1 and np.array_equal(o1, o2)
    assert tr1.all() and not te1.any()
    assert i1["_final_obs"].all()
    # the last observation is the twin's, but for the body poses: the GPU path observes a
    # finished world before the step's position pass (its poses are a substep older; the
    # twin's running worlds are observed after it), so poses and body velocities agree to a
    # substep's motion
    joints = slice(0, 72)  # both hands' joint positions, velocities and forces
    assert np.array_equal(i1["final_obs"][:, joints], o2[:, joints])
    assert np.allclose(i1["final_obs"], o2, atol=0.1)  # 0.07 at most here (angular velocities)
    assert not np.array_equal(o1, o2)  # the new episodes' first observations
    assert np.all(i1["episode"]["l"] == 4) and i1["_episode"].all()


def test_a_nan_action_faults_and_resets_that_world_only_on_the_gpu_path():
    env = make(seed=3)
    env.reset()
    a = np.zeros((3, 52), np.float32)
    a[2, 7] = np.nan
    obs, _, term, trunc, info = env.step(a)
    assert info["fault"].tolist() == [False, False, True]
    assert trunc[2] and not term[2]
    assert np.all(np.isfinite(obs))


def test_gpu_pack_errors_name_the_expected_and_the_actual_value():
    with pytest.raises(ValueError, match=r"render_mode: expected None on device 'warp-cpu'"):
        make(render_mode="rgb_array")
    with pytest.raises(ValueError, match=r"device: expected 'cpu', 'cuda', 'cuda:N' or "
                                         r"'warp-cpu', got 'cuda:x'"):
        bidex.make_vec(TASK, 2, device="cuda:x")
    env = make()
    env.reset()
    with pytest.raises(ValueError, match=r"expected shape \(3, 52\), got \(3, 40\)"):
        env.step(np.zeros((3, 40), np.float32))
    with pytest.raises(ValueError, match=r"pack: obs: expected a CPU pack \(device 'cpu'\), got "
                                         r"a pack on 'warp-cpu'"):
        env._pack.obs
