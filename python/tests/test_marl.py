"""The multi-agent view (bidex.make_marl): PettingZoo's Parallel API checks written out for
batched arrays (its parallel_api_test expects one world per env), the splits against
``bidex info --agents``, and the same results as the vector env it views."""
import json
import os
import subprocess

import numpy as np
import pytest

import bidex

BINARY = os.environ.get("BIDEX_BINARY", "")


@pytest.mark.parametrize("agents", ["hand", "finger"])
def test_the_split_is_bidex_infos(agents):
    env = bidex.make_marl("catch_abreast", 3, agents=agents, seed=1, threads=1)
    assert len(env.possible_agents) == (2 if agents == "hand" else 12)
    cols = np.sort(np.concatenate([env.split[a]["act_columns"] for a in env.possible_agents]))
    assert np.array_equal(cols, np.arange(52))  # every action column, exactly once
    if not BINARY:
        pytest.skip("BIDEX_BINARY not set")
    info = json.loads(subprocess.run([BINARY, "info", "--task", "catch_abreast", "--agents",
                                      agents, "--json"], check=True, capture_output=True,
                                     text=True).stdout)
    assert [a["name"] for a in info["agents"]] == env.possible_agents
    for a in info["agents"]:
        assert env.split[a["name"]]["obs_columns"] == a["obs_columns"]
        assert env.split[a["name"]]["act_columns"] == a["act_columns"]


def test_parallel_api_contract():
    env = bidex.make_marl("hand_over", 4, agents="finger", seed=2, threads=1)
    assert env.agents == env.possible_agents
    for a in env.possible_agents:
        assert env.observation_space(a) is env.observation_space(a)
        assert env.action_space(a) is env.action_space(a)
    obs, infos = env.reset(seed=2)
    assert set(obs) == set(infos) == set(env.agents)
    for a in env.agents:
        assert obs[a].shape == env.observation_space(a).shape
        assert obs[a].dtype == np.float32 and env.observation_space(a).contains(obs[a])
    for _ in range(80):  # past the 75-step episodes: worlds reset, agents stay
        actions = {a: env.action_space(a).sample() for a in env.agents}
        obs, rew, term, trunc, infos = env.step(actions)
        for d in (obs, rew, term, trunc, infos):
            assert set(d) == set(env.possible_agents)
        for a in env.agents:
            assert env.observation_space(a).contains(obs[a])
            assert rew[a].shape == (4,) and term[a].dtype == bool and trunc[a].dtype == bool
            if "final_obs" in infos[a]:
                assert infos[a]["final_obs"].shape == obs[a].shape
    assert env.agents == env.possible_agents
    assert env.state().shape == env.state_space.shape


def test_the_view_steps_as_the_vector_env_does():
    marl = bidex.make_marl("catch_underarm", 3, agents="finger", seed=5, threads=1)
    vec = bidex.make_vec("catch_underarm", 3, seed=5, threads=1)
    obs, _ = marl.reset()
    full, _ = vec.reset()
    rng = np.random.default_rng(0)
    for _ in range(20):
        a = rng.uniform(-1, 1, vec.action_space.shape).astype(np.float32)
        per = {n: a[:, marl.split[n]["act_columns"]] for n in marl.agents}
        obs, rew, term, trunc, _ = marl.step(per)
        full, r, te, tr, _ = vec.step(a)
        assert np.array_equal(marl.state(), full)
        for n in marl.agents:
            assert np.array_equal(obs[n], full[:, marl.split[n]["obs_columns"]])
            assert np.array_equal(rew[n], r) and np.array_equal(term[n], te)


def test_bad_agents_and_actions_name_what_is_wrong(tmp_path):
    with pytest.raises(ValueError, match=r"agents: expected 'hand', 'finger' or the path .*got 'toes'"):
        bidex.make_marl("hand_over", 2, agents="toes")
    bad = tmp_path / "bad.yaml"
    bad.write_text("- {name: r, act: [right.joints]}\n")  # the left hand's columns uncovered
    with pytest.raises(ValueError, match="bad.yaml"):
        bidex.make_marl("hand_over", 2, agents=str(bad))
    with pytest.raises(ValueError, match=r"suites have no multi-agent view"):
        bidex.make_marl("MT4", 2)
    env = bidex.make_marl("hand_over", 2, agents="hand")
    env.reset()
    with pytest.raises(ValueError, match=r"expected one array for each agent of \['right', 'left'\]"):
        env.step({"right": np.zeros((2, 20), np.float32)})
    with pytest.raises(ValueError, match=r"actions\['left'\]: expected shape \(2, 20\), got \(2, 3\)"):
        env.step({"right": np.zeros((2, 20), np.float32), "left": np.zeros((2, 3), np.float32)})
    with pytest.raises(KeyError, match="agent: expected one of"):
        env.observation_space("middle")
    # a custom split from a file, in bidex train --agents's format
    f = tmp_path / "agents.yaml"
    f.write_text("- {name: both, act: [right.joints, left.joints]}\n")
    one = bidex.make_marl("hand_over", 2, agents=str(f))
    assert one.possible_agents == ["both"]
    assert one.action_space("both").shape == (2, 40)
