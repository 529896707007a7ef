"""The stable-baselines3 VecEnv on the Rust batch."""

from __future__ import annotations

import copy
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from stable_baselines3 import PPO
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import VecEnv, VecMonitor, VecNormalize

from chaincart_env import ChainCartError, ChainCartVecEnv, ChainCartVectorEnv

CONFIG = dict(n_links=2, start_noise=0.25, max_episode_steps=15, track_limit=0.3, max_force=20.0)


def test_importing_the_package_does_not_import_sb3_or_torch() -> None:
    code = "import sys, chaincart_env; print('stable_baselines3' in sys.modules, 'torch' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False"]


def test_it_is_a_vecenv_with_same_step_autoreset_matching_the_gymnasium_vector_env() -> None:
    n = 33
    venv = ChainCartVecEnv(n, seed=50, **CONFIG)
    assert isinstance(venv, VecEnv) and venv.num_envs == n
    ref = ChainCartVectorEnv(n, autoreset_mode=AutoresetMode.SAME_STEP, **CONFIG)
    obs = venv.reset()
    ref_obs, _ = ref.reset(seed=50)
    assert np.array_equal(obs, ref_obs) and obs.dtype == np.float32
    rng = np.random.default_rng(0)
    dones_seen = 0
    for _ in range(40):
        a = rng.uniform(-1, 1, (n, 1)).astype(np.float32)
        obs, rewards, dones, infos = venv.step(a)
        r_obs, r_rew, r_term, r_trunc, r_info = ref.step(a)
        assert np.array_equal(obs, r_obs)
        assert rewards.dtype == np.float32 and np.array_equal(rewards, r_rew.astype(np.float32))
        assert np.array_equal(dones, r_term | r_trunc) and dones.dtype == np.bool_
        assert isinstance(infos, list) and len(infos) == n
        for i in range(n):
            if not dones[i]:
                assert infos[i] == {"TimeLimit.truncated": False}  # in every info, as DummyVecEnv
                continue
            dones_seen += 1
            info = infos[i]
            assert np.array_equal(info["terminal_observation"], r_info["final_obs"][i])
            assert info["TimeLimit.truncated"] == bool(r_trunc[i] and not r_term[i])
            for key in ("is_success", "numerical_failure", "out_of_track", "fell", "e_q", "e_w"):
                assert info[key] == r_info["final_info"][key][i]
    assert dones_seen > n


def test_seed_reset_reproduces_and_attributes() -> None:
    venv = ChainCartVecEnv(4, n_links=2, start_noise=0.2)
    assert venv.seed(7) == [7, 8, 9, 10]
    a = venv.reset()
    venv.seed(7)
    assert np.array_equal(venv.reset(), a)
    assert not np.array_equal(venv.reset(), a)  # no seed: streams continue
    assert venv.get_attr("dt") == [0.02] * 4
    assert venv.get_attr("render_mode", indices=[1, 2]) == [None, None]
    states = venv.get_attr("model_state")
    assert len(states) == 4 and np.array_equal(states[3], venv.get_attr("model_state", 3)[0])
    assert venv.get_attr("state")[0].shape == (16,)
    venv.env_method("set_state", np.array([0.1, 0.0, 0.0, -1.0, 0.0, -1.0, 0.0, 0.0]), indices=[2])
    assert np.array_equal(venv.get_attr("model_state", 2)[0], [0.1, 0.0, 0.0, -1.0, 0.0, -1.0, 0.0, 0.0])
    assert venv.env_method("get_wrapper_attr", "dt", indices=0) == [0.02]
    assert venv.env_is_wrapped(Monitor) == [False] * 4
    venv.set_attr("note", "everyone")
    assert venv.get_attr("note") == ["everyone"] * 4
    venv.set_attr("note", "one", indices=[0])  # a name the VecEnv lacks is per env
    assert venv.get_attr("note") == ["one"] + ["everyone"] * 3
    with pytest.raises(ChainCartError, match="'config' is shared by all 4 envs"):
        venv.set_attr("config", venv.config, indices=[0])
    with pytest.raises(AttributeError):
        venv.get_attr("no_such_attribute")
    assert venv.config.n_links == 2 and venv.model.n_links == 2


def test_bad_actions_raise_and_change_nothing() -> None:
    venv = ChainCartVecEnv(3, seed=0)
    venv.reset()
    before = venv.get_attr("model_state")
    bad = np.zeros((3, 1), np.float32)
    bad[1] = np.nan
    with pytest.raises(ChainCartError, match="NaN"):
        venv.step(bad)
    with pytest.raises(ChainCartError, match="expected"):
        venv.step(np.zeros((3, 2), np.float32))
    for a, b in zip(before, venv.get_attr("model_state")):
        assert np.array_equal(a, b)


def test_vec_monitor_and_vec_normalize_wrap_it() -> None:
    venv = VecNormalize(VecMonitor(ChainCartVecEnv(8, seed=1, **CONFIG)), gamma=0.99)
    obs = venv.reset()
    assert obs.shape == (8, 8)
    episodes = []
    for _ in range(60):
        obs, rewards, dones, infos = venv.step(np.random.default_rng(0).uniform(-1, 1, (8, 1)).astype(np.float32))
        episodes += [info["episode"] for info in infos if "episode" in info]
        assert np.all(np.isfinite(obs)) and np.all(np.isfinite(rewards))
        for info, done in zip(infos, dones):
            if done:  # VecNormalize normalises the terminal observation too
                assert info["terminal_observation"].shape == (8,)
    assert len(episodes) >= 8 and all(e["l"] <= 15 for e in episodes)


def test_a_short_ppo_run_learns_without_errors() -> None:
    venv = VecMonitor(ChainCartVecEnv(4, seed=0))
    model = PPO("MlpPolicy", venv, n_steps=64, batch_size=64, n_epochs=2, seed=0, device="cpu", verbose=0)
    model.learn(total_timesteps=512)
    assert model.num_timesteps >= 512
    action, _ = model.predict(venv.reset(), deterministic=True)
    assert action.shape == (4, 1) and np.all(np.abs(action) <= 1.0)


def test_copies_continue_identically() -> None:
    venv = ChainCartVecEnv(5, seed=3, **CONFIG)
    venv.reset()
    acts = np.random.default_rng(2).uniform(-1, 1, (30, 5, 1)).astype(np.float32)
    for a in acts[:7]:
        venv.step(a)
    twin = copy.deepcopy(venv)
    for a in acts[7:]:
        x, y = venv.step(a), twin.step(a)
        assert all(np.array_equal(u, v) for u, v in zip(x[:3], y[:3]))


def test_gymnasium_make_vec_is_the_native_vector_env() -> None:
    envs = gym.make_vec("ChainCart-v0", num_envs=3, vectorization_mode="vector_entry_point")
    assert isinstance(envs.unwrapped, ChainCartVectorEnv) and envs.num_envs == 3
