"""Contract tests of bidex's Gymnasium vector environment (python/README.md), on the CPU core.

ctest runs them (python/CMakeLists.txt) with PYTHONPATH at the build tree's package and
BIDEX_BINARY at the bidex command, whose results they are compared with.
"""
import json
import os
import subprocess

import gymnasium as gym
import numpy as np
import pytest

import bidex

BINARY = os.environ.get("BIDEX_BINARY", "")


def zeros(env):
    return np.zeros(env.action_space.shape, np.float32)


def rollout(env, actions):
    """obs, rewards, terminations, truncations of each step, stacked"""
    out = []
    for a in actions:
        o, r, te, tr, _ = env.step(a)
        out.append((o, r, te, tr))
    return [np.stack(x) for x in zip(*out)]


# ---- spaces, shapes, layouts --------------------------------------------------------------

def test_every_task_has_a_registered_id_and_its_spec_sizes():
    ids = bidex.task_ids()
    assert len(bidex.paper_task_ids()) == 20
    assert len(ids) == 22 and ids[:20] == bidex.paper_task_ids()
    for t in ids:
        assert f"bidex/{t}-v0" in gym.registry
        spec = bidex.task_spec(t)
        assert spec["obs_dim"] == sum(s["size"] for s in spec["obs"])
        assert spec["act_dim"] == sum(s["size"] for s in spec["act"])


@pytest.mark.parametrize("task", ["hand_over", "catch_abreast", "pour_water"])
def test_spaces_dtypes_and_shapes_match_the_spec(task):
    spec = bidex.task_spec(task)
    env = bidex.make_vec(task, 3, seed=1, threads=1)
    assert env.num_envs == 3
    assert env.metadata["autoreset_mode"] == gym.vector.AutoresetMode.SAME_STEP
    assert env.single_observation_space.shape == (spec["obs_dim"],)
    assert env.single_action_space.shape == (spec["act_dim"],)
    assert env.observation_space.shape == (3, spec["obs_dim"])
    assert env.action_space.shape == (3, spec["act_dim"])
    assert env.single_observation_space.dtype == np.float32
    assert env.single_action_space.dtype == np.float32
    assert np.all(env.single_action_space.low == -1) and np.all(env.single_action_space.high == 1)
    obs, info = env.reset()
    assert obs.shape == (3, spec["obs_dim"]) and obs.dtype == np.float32
    assert env.observation_space.contains(obs)
    assert info == {}
    obs, rew, term, trunc, info = env.step(env.action_space.sample())
    assert obs.dtype == np.float32 and rew.shape == (3,) and rew.dtype == np.float32
    assert term.shape == (3,) and term.dtype == bool
    assert trunc.shape == (3,) and trunc.dtype == bool
    assert env.observation_space.contains(obs)


def test_layout_is_the_bidex_info_layout():
    env = bidex.make_vec("catch_abreast", 1)
    assert env.layout.obs["object.pose"] == slice(398, 405)
    assert env.layout.act["right.joints"] == slice(0, 20)
    if not BINARY:
        pytest.skip("BIDEX_BINARY not set")
    info = json.loads(subprocess.run([BINARY, "info", "--task", "catch_abreast", "--json"],
                                     check=True, capture_output=True, text=True).stdout)
    for key in ("obs", "act"):
        rows = info[key] if isinstance(info[key], list) else info[key]["slices"]
        got = getattr(env.layout, key)
        assert list(got) == [r["name"] for r in rows]
        for r in rows:
            assert got[r["name"]] == slice(r["start"], r["start"] + r["size"])


def test_gymnasium_make_vec_builds_the_task():
    env = gym.make_vec("bidex/hand_over-v0", num_envs=2)
    assert isinstance(env, bidex.BidexVectorEnv)
    assert env.num_envs == 2 and env.name == "hand_over"
    obs, _ = env.reset(seed=5)
    assert obs.shape == (2, bidex.task_spec("hand_over")["obs_dim"])


# ---- determinism --------------------------------------------------------------------------

def test_same_seed_same_actions_give_identical_results_for_any_thread_count():
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1, 1, (40, 4, 52)).astype(np.float32)
    a = bidex.make_vec("catch_underarm", 4, seed=7, threads=1)
    b = bidex.make_vec("catch_underarm", 4, seed=7, threads=2)
    c = bidex.make_vec("catch_underarm", 4, seed=8, threads=1)
    oa, _ = a.reset()
    ob, _ = b.reset()
    oc, _ = c.reset()
    assert np.array_equal(oa, ob) and not np.array_equal(oa, oc)
    ra, rb = rollout(a, acts), rollout(b, acts)
    for x, y in zip(ra, rb):
        assert np.array_equal(x, y)
    # reset(seed=s) starts the same streams as a new env with seed s
    a.reset(seed=8)
    assert a.seed_value == 8
    d = bidex.make_vec("catch_underarm", 4, seed=8, threads=1)
    d.reset()
    for x, y in zip(rollout(a, acts), rollout(d, acts)):
        assert np.array_equal(x, y)
    # a seeded reset repeats itself; an unseeded one starts new episodes
    first, _ = a.reset(seed=8)
    again, _ = a.reset(seed=8)
    other, _ = a.reset()
    assert np.array_equal(first, again) and not np.array_equal(first, other)


def test_values_match_the_cpp_path_of_bidex_play(tmp_path):
    # bidex play --policy zero steps the same task with the same seed on the core's own loop; its
    # per-step minimum and maximum of every reward term are float32 values it read, so they must
    # be equal to the last bit, and its episode means equal to rounding
    if not BINARY:
        pytest.skip("BIDEX_BINARY not set")
    task, slots, steps, seed = "hand_over", 6, 160, 3
    subprocess.run([BINARY, "play", "--task", task, "--policy", "zero", "--steps", str(steps),
                    "--slots", str(slots), "--seed", str(seed), "--threads", "1", "--device",
                    "cpu", "--json", str(tmp_path / "play.json")], check=True, capture_output=True)
    play = json.loads((tmp_path / "play.json").read_text())
    env = bidex.make_vec(task, slots, seed=seed, threads=1)
    env.reset()
    terms, rewards, returns, lengths = {}, [], [], []
    for _ in range(steps):
        _, r, _, _, info = env.step(zeros(env))
        rewards.append(r)
        for name, v in info["terms"].items():
            terms.setdefault(name, []).append(v)
        if "episode" in info:
            returns += list(info["episode"]["r"][info["_episode"]])
            lengths += list(info["episode"]["l"][info["_episode"]])
    for name, rows in list(terms.items()) + [("reward (sum)", rewards)]:
        v = np.stack(rows).astype(np.float64)
        assert v.max() == play["terms"][name]["max"], name
        assert v.min() == play["terms"][name]["min"], name
    assert len(returns) == play["episodes"]["count"] > 0
    assert np.mean(returns) == pytest.approx(play["episodes"]["mean_return"], rel=1e-6)
    assert np.mean(lengths) == pytest.approx(play["episodes"]["mean_length"], rel=1e-12)


# ---- autoreset (SAME_STEP), final_obs and infos ---------------------------------------------

def test_same_step_reset_hands_back_the_true_last_observation():
    # Two envs, the same seed and actions, one with a 10-step longer episode: where the first's
    # episodes end (truncation at 75), its final_obs must be the second's observation of that
    # step, and its obs a new episode's
    short = bidex.make_vec("hand_over", 3, seed=4, threads=1)
    long = bidex.make_vec("hand_over", 3, seed=4, threads=1, overrides={"episode_length": 85})
    short.reset()
    long.reset()
    rng = np.random.default_rng(1)
    for t in range(1, 77):
        a = rng.uniform(-1, 1, short.action_space.shape).astype(np.float32)
        o1, r1, te1, tr1, i1 = short.step(a)
        o2, r2, te2, tr2, i2 = long.step(a)
        done = te1 | tr1
        if t < 75:
            assert not done.any()
            assert np.array_equal(o1, o2) and np.array_equal(r1, r2)
            assert "final_obs" not in i1 and "_final_obs" not in i1
        if t == 75:
            assert tr1.all() and not te1.any() and not (te2 | tr2).any()
            assert i1["_final_obs"].dtype == bool and i1["_final_obs"].all()
            assert i1["final_obs"].shape == o1.shape and i1["final_obs"].dtype == np.float32
            assert np.array_equal(i1["final_obs"], o2)         # the true last observation
            assert np.array_equal(r1, r2)                       # the ending step's reward
            assert not np.array_equal(o1, o2)                   # the obs is the new episode's
            assert np.array_equal(i1["_episode"], done)
            assert np.all(i1["episode"]["l"] == 75)
        if t == 76:
            assert "final_obs" not in i1


def test_final_obs_rows_of_running_worlds_are_zero_and_masked_out():
    env = bidex.make_vec("catch_abreast", 8, seed=2, threads=1)
    env.reset()
    rng = np.random.default_rng(3)
    seen = False
    for _ in range(200):
        _, r, te, tr, info = env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
        done = te | tr
        if not done.any():
            continue
        if not done.all():
            seen = True
        m = info["_final_obs"]
        assert np.array_equal(m, done)
        assert np.all(info["final_obs"][~m] == 0)
        assert np.all(info["episode"]["r"][~m] == 0) and np.all(info["episode"]["l"][~m] == 0)
        assert np.all(info["episode"]["l"][m] >= 1)
    assert seen  # some step ended some worlds and not others


def test_infos_carry_success_faults_and_the_reward_terms():
    env = bidex.make_vec("catch_abreast", 4, seed=1, threads=1)
    env.reset()
    _, r, _, _, info = env.step(zeros(env))
    names = [t["name"] for t in bidex.task_spec("catch_abreast")["reward_terms"]]
    assert list(info["terms"]) == names
    total = sum(info["terms"][n].astype(np.float64) for n in names)
    assert np.allclose(total, r, rtol=1e-6, atol=1e-6)  # the reward is the sum of its terms
    for k in ("success", "fault", "terms"):
        assert info[f"_{k}"].shape == (4,) and info[f"_{k}"].all()
    assert info["success"].dtype == bool and info["fault"].dtype == bool


def test_nan_actions_fault_and_reset_that_world_only():
    env = bidex.make_vec("catch_underarm", 3, seed=1, threads=1)
    env.reset()
    a = zeros(env)
    a[1, 4] = np.nan
    obs, _, term, trunc, info = env.step(a)
    assert info["fault"].tolist() == [False, True, False]
    assert trunc[1] and not term[1] and info["_final_obs"][1]
    assert np.all(np.isfinite(obs))
    obs, *_ = env.step(zeros(env))  # and the env goes on
    assert np.all(np.isfinite(obs))


# ---- suites -------------------------------------------------------------------------------

def test_a_multitask_suite_is_one_pack_with_one_hot_ids():
    env = bidex.make_vec("MT4", 8, seed=0, threads=1)
    assert env.name == "MT4/train" and len(env.entries) == 4 and env.layout is None
    obs, _ = env.reset()
    assert [e["num_envs"] for e in env.entries] == [2, 2, 2, 2]
    for g, e in enumerate(env.entries):
        rows = obs[e["first_env"]:e["first_env"] + e["num_envs"]]
        hot = rows[:, e["one_hot_column"]]
        assert np.all(hot == 1)
        assert np.all(env.entry_of_env[e["first_env"]:e["first_env"] + e["num_envs"]] == g)
    env.step(zeros(env))


def test_a_meta_suite_masks_the_goal_and_has_a_test_split():
    env = bidex.make_vec("ML1", 4, seed=0, split="test", threads=1)
    assert env.name == "ML1/test"
    e = env.entries[0]
    assert e["one_hot_column"] == -1
    assert not e["obs_keep"].all()  # the goal slices are zeroed
    obs, _ = env.reset()
    assert np.all(obs[:, :len(e["obs_keep"])][:, ~e["obs_keep"]] == 0)


# ---- errors -------------------------------------------------------------------------------

def test_bad_input_raises_errors_that_name_the_expected_and_the_actual_value():
    with pytest.raises(ValueError, match=r"task: expected one of the task ids .*got 'catch'"):
        bidex.make_vec("catch", 2)
    with pytest.raises(ValueError, match=r"num_envs: expected an integer >= 1, got 0"):
        bidex.make_vec("hand_over", 0)
    with pytest.raises(ValueError, match=r"device: expected 'cpu'.*got 'tpu'"):
        bidex.make_vec("hand_over", 2, device="tpu")
    with pytest.raises(ValueError, match=r"reward\.goal_bonuss.*unknown key 'goal_bonuss'"):
        bidex.make_vec("hand_over", 2, overrides={"reward.goal_bonuss": 0})
    with pytest.raises(ValueError, match=r"split: expected 'train' or 'test', got 'val'"):
        bidex.make_vec("ML1", 2, split="val")
    env = bidex.make_vec("hand_over", 2)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(zeros(env))
    env.reset()
    with pytest.raises(ValueError, match=r"expected shape \(2, 40\), got \(2, 52\)"):
        env.step(np.zeros((2, 52), np.float32))
    with pytest.raises(TypeError, match=r"expected a float array \(float32\), got dtype int64"):
        env.step(np.zeros((2, 40), np.int64))
    env.step(np.zeros((2, 40), np.float64))  # any float converts


def test_overrides_change_the_task():
    env = bidex.make_vec("hand_over", 2, overrides={"episode_length": 5})
    env.reset()
    for t in range(5):
        _, _, te, tr, _ = env.step(zeros(env))
    assert tr.all()
    nested = bidex.make_vec("hand_over", 2, overrides={"reward": {"goal_bonus": 0}})
    nested.reset()


# ---- rendering ----------------------------------------------------------------------------

def test_render_gives_pictures_of_the_chosen_worlds():
    env = bidex.make_vec("hand_over", 3, seed=1, threads=1, render_mode="rgb_array",
                         render_worlds=[0, 2], render_size=(64, 48))
    assert "rgb_array" in env.metadata["render_modes"]
    env.reset()
    frames = env.render()
    assert len(frames) == 2
    for f in frames:
        assert f.shape == (48, 64, 3) and f.dtype == np.uint8
        assert f.std() > 5  # a scene, not a blank image
    env.step(env.action_space.sample())
    after = env.render()
    assert not np.array_equal(after[0], frames[0])  # the hands moved
    assert bidex.make_vec("hand_over", 1).render() is None  # no render_mode: nothing drawn
    with pytest.raises(ValueError, match=r"render_worlds: expected worlds in \[0, 3\), got \[3\]"):
        bidex.make_vec("hand_over", 3, render_mode="rgb_array", render_worlds=[3])
    with pytest.raises(ValueError, match=r"render_mode: expected None or 'rgb_array', got 'human'"):
        bidex.make_vec("hand_over", 1, render_mode="human")
