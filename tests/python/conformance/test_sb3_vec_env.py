"""stable-baselines3's generic VecEnv tests (test_vec_envs.py, test_vec_normalize.py,
test_vec_monitor.py, test_vec_check_nan.py, test_save_load.py) on ChainCartVecEnv,
with DummyVecEnv(ChainCartEnv) as the reference."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import (
    DummyVecEnv,
    VecCheckNan,
    VecFrameStack,
    VecMonitor,
    VecNormalize,
    sync_envs_normalization,
    unwrap_vec_normalize,
)

from chaincart_env import ChainCartEnv, ChainCartError, ChainCartVecEnv

CONFIG = dict(n_links=2, start_noise=0.25, max_episode_steps=15, track_limit=0.3, max_force=20.0)
N = 3
INDEX_FORMS = [None, 0, 2, -1, -3, [0, 2], (1,), [-1, 0], range(1, 3), np.array([2, 0]), []]


def expected_indices(indices: Any) -> list[int]:
    if indices is None:
        return list(range(N))
    items = [indices] if isinstance(indices, (int, np.integer)) else list(indices)
    return [int(i) % N for i in items]


def reference(**kwargs: Any) -> DummyVecEnv:
    return DummyVecEnv([lambda: ChainCartEnv(**{**CONFIG, **kwargs}) for _ in range(N)])


def wrapped(venv: Any, wrapper: Any) -> Any:
    if wrapper is None:
        return venv
    return VecFrameStack(venv, n_stack=2) if wrapper is VecFrameStack else wrapper(venv)


@pytest.mark.parametrize("wrapper", [None, VecNormalize, VecFrameStack])
def test_vecenv_custom_calls(wrapper: Any) -> None:
    venv = wrapped(ChainCartVecEnv(N, render_mode="rgb_array", render_width=48, render_height=24, **CONFIG), wrapper)
    venv.seed(0)
    venv.reset()
    np.testing.assert_array_equal(venv.render(mode="rgb_array"), venv.render())
    with pytest.warns(UserWarning):
        venv.render(mode="something_else")
    assert not venv.has_attr("dummy")
    venv.set_attr("dummy", 12)
    assert venv.get_attr("dummy") == [12] * N
    assert not venv.has_attr("dummy2")
    assert venv.env_method("set_wrapper_attr", "dummy2", 2) == [True] * N
    assert venv.get_attr("dummy2") == [2] * N
    for i in range(N):
        assert venv.set_attr("dummy1", i, indices=i) is None
    assert venv.has_attr("dummy1") and venv.get_attr("dummy1") == list(range(N))
    venv.set_attr("dummy1", 42, indices=None)
    assert venv.get_attr("dummy1") == [42] * N
    assert venv.env_method("set_wrapper_attr", "current_step", 12, indices=[0, -1]) == [True, True]
    assert venv.get_attr("current_step", indices=[0, 2]) == [12, 12]
    with pytest.raises(AttributeError):
        venv.get_attr("current_step", indices=1)


@pytest.mark.parametrize("indices", INDEX_FORMS, ids=repr)
def test_every_index_form_reaches_the_same_envs_as_in_dummy_vec_env(indices: Any) -> None:
    venv, ref = ChainCartVecEnv(N, seed=7, **CONFIG), reference()
    ref.seed(7)
    venv.reset()
    ref.reset()
    ours = venv.get_attr("model_state", indices)
    theirs = ref.get_attr("model_state", indices)
    assert data_equivalence(ours, theirs, exact=True)
    assert len(ours) == len(expected_indices(indices))
    assert venv.env_method("get_wrapper_attr", "elapsed_steps", indices=indices) == [0] * len(ours)
    venv.set_attr("mark", "x", indices)
    ref.set_attr("mark", "x", indices)
    for i in range(N):
        if i in expected_indices(indices):
            assert venv.get_attr("mark", i) == ref.get_attr("mark", i) == ["x"]
        else:
            with pytest.raises(AttributeError):
                venv.get_attr("mark", i)


@pytest.mark.parametrize("bad, error", [(N, IndexError), (-N - 1, IndexError), ("0", TypeError), ([0.5], TypeError)])
def test_bad_indices_raise_like_a_list(bad: Any, error: type) -> None:
    venv = ChainCartVecEnv(N)
    with pytest.raises(error):
        venv.get_attr("dt", bad)


def test_set_attr_of_a_per_env_attribute_sets_only_the_envs_given() -> None:
    venv = ChainCartVecEnv(N, seed=1, **CONFIG)
    venv.reset()
    states = venv.get_attr("model_state")
    venv.set_attr("model_state", states[0], indices=[1, -1])
    after = venv.get_attr("model_state")
    assert np.array_equal(after[1], states[0]) and np.array_equal(after[2], states[0])
    assert np.array_equal(after[0], states[0])
    venv.set_attr("state", ChainCartEnv(**CONFIG).model.to_spatial(states[1]), indices=0)
    assert np.array_equal(venv.get_attr("model_state", 0)[0], states[1])
    with pytest.raises(ChainCartError, match="'config' is shared by all 3 envs"):
        venv.set_attr("config", venv.config, indices=[0, 1])
    venv.set_attr("config", venv.config, indices=[2, 0, 1])  # all envs: allowed


def test_set_options_reach_each_envs_next_reset_only() -> None:
    venv = ChainCartVecEnv(N, seed=2, **CONFIG)
    venv.reset()
    upright = ChainCartEnv(**CONFIG).model.equilibrium([-1, -1])
    venv.set_options({"state": upright})
    obs = venv.reset()
    assert all(np.array_equal(o, upright.astype(np.float32)) for o in obs)
    assert all(np.array_equal(s, upright) for s in venv.get_attr("model_state"))
    moved = upright.copy()
    moved[0] = 0.1
    venv.set_options([{"state": moved}, {}, {"state": upright}])
    obs = venv.reset()
    assert np.array_equal(obs[0], moved.astype(np.float32)) and np.array_equal(obs[2], upright.astype(np.float32))
    assert not np.array_equal(obs[1], upright.astype(np.float32))  # its own noisy start
    assert not any(np.array_equal(o, moved.astype(np.float32)) for o in venv.reset())  # options used once
    venv.set_options({"no such option": 1})
    with pytest.raises(ChainCartError, match="unknown keys"):
        venv.reset()


@pytest.mark.parametrize("diagnostics", [False, True])
def test_infos_match_dummy_vec_env_of_the_single_env(diagnostics: bool) -> None:
    venv, ref = ChainCartVecEnv(N, seed=11, diagnostics=diagnostics, **CONFIG), reference(diagnostics=diagnostics)
    ref.seed(11)
    assert np.array_equal(venv.reset(), ref.reset())
    assert venv.reset_infos == ref.reset_infos
    rng = np.random.default_rng(3)
    dones = 0
    for _ in range(40):
        actions = rng.uniform(-1, 1, (N, 1)).astype(np.float32)
        obs, rewards, done, infos = venv.step(actions)
        r_obs, r_rewards, r_done, r_infos = ref.step(actions)
        assert np.array_equal(obs, r_obs) and np.array_equal(rewards, r_rewards) and np.array_equal(done, r_done)
        assert data_equivalence(infos, r_infos, exact=True), (infos, r_infos)
        assert all("TimeLimit.truncated" in info for info in infos)
        dones += int(done.sum())
    assert dones > N


def test_stepping_before_reset_raises_like_dummy_vec_env() -> None:
    from gymnasium.error import ResetNeeded

    with pytest.raises(ResetNeeded):
        ChainCartVecEnv(N).step(np.zeros((N, 1), np.float32))
    with pytest.raises(ResetNeeded):
        DummyVecEnv([lambda: __import__("gymnasium").make("ChainCart-v0")]).step(np.zeros((1, 1), np.float32))


# -- VecNormalize, VecMonitor, VecCheckNan ------------------------------------------------


def test_vec_normalize_clips_saves_and_loads(tmp_path: Path) -> None:
    clip_obs, clip_reward = 0.5, 5.0
    original = ChainCartVecEnv(1, seed=0, **CONFIG)
    norm = VecNormalize(original, norm_obs=True, norm_reward=True, clip_obs=clip_obs, clip_reward=clip_reward)
    assert norm.render_mode is None
    norm.reset()
    done = [False]
    while not done[0]:
        obs, reward, done, _ = norm.step([norm.action_space.sample()])
        assert np.max(np.abs(obs)) <= clip_obs and np.max(np.abs(reward)) <= clip_reward
    norm.save(tmp_path / "vec_normalize.pkl")
    loaded = VecNormalize.load(tmp_path / "vec_normalize.pkl", venv=original)
    np.testing.assert_array_equal(loaded.obs_rms.mean, norm.obs_rms.mean)
    np.testing.assert_array_equal(loaded.ret_rms.var, norm.ret_rms.var)
    rendered = ChainCartVecEnv(1, render_mode="rgb_array", render_width=48, render_height=24)
    assert VecNormalize.load(tmp_path / "vec_normalize.pkl", venv=rendered).render_mode == "rgb_array"


def test_sync_vec_normalize() -> None:
    env = VecNormalize(ChainCartVecEnv(1, seed=0, **CONFIG), clip_obs=100.0, clip_reward=100.0)
    assert isinstance(unwrap_vec_normalize(VecFrameStack(env, 1)), VecNormalize)
    evaluation = VecNormalize(ChainCartVecEnv(1, **CONFIG), training=False, clip_obs=100.0, clip_reward=100.0)
    env.reset()
    latest = None
    for _ in range(100):
        _, latest, _, _ = env.step([env.action_space.sample()])
    assert np.allclose(env.get_original_reward(), env.unnormalize_reward(latest))
    obs = env.reset()
    original = env.get_original_obs()
    assert np.allclose(original, env.unnormalize_obs(obs))
    assert not np.allclose(obs, evaluation.normalize_obs(original))
    sync_envs_normalization(env, evaluation)
    assert np.allclose(obs, evaluation.normalize_obs(original))


def test_vec_monitor_counts_episodes_and_writes_its_file(tmp_path: Path) -> None:
    monitor_file = tmp_path / "chaincart.monitor.csv"
    venv = VecMonitor(ChainCartVecEnv(2, seed=0, **CONFIG), str(monitor_file), info_keywords=("is_success",))
    venv.reset()
    lengths, returns = np.zeros(2, int), np.zeros(2)
    episodes = 0
    for _ in range(60):
        _, rewards, dones, infos = venv.step(np.zeros((2, 1), np.float32))
        lengths += 1
        returns += rewards
        for i in np.flatnonzero(dones):
            assert infos[i]["episode"]["l"] == lengths[i]
            assert infos[i]["episode"]["r"] == pytest.approx(returns[i], abs=1e-5)
            lengths[i], returns[i] = 0, 0.0
            episodes += 1
    venv.close()
    lines = monitor_file.read_text().splitlines()
    assert set(json.loads(lines[0][1:])) == {"t_start", "env_id"}
    assert lines[1] == "r,l,t,is_success" and len(lines) == 2 + episodes and episodes >= 4


def test_vec_check_nan_finds_nothing_even_when_the_integration_fails() -> None:
    # A 1 s control period with full force fails numerically: the episode ends
    # flagged, its observations stay finite, so VecCheckNan stays silent.
    venv = VecCheckNan(ChainCartVecEnv(2, seed=0, dt=1.0, substeps=1, max_force=100.0), raise_exception=True)
    venv.reset()
    failures = 0
    for _ in range(10):
        _, _, dones, infos = venv.step(np.ones((2, 1), np.float32))
        failures += sum(bool(info.get("numerical_failure")) for info in infos)
    assert failures > 0
    with pytest.raises(ValueError):  # VecCheckNan's own check of the actions
        venv.step(np.full((2, 1), np.nan, np.float32))


# -- saving and loading a model ------------------------------------------------------------


def test_save_load_reproduces_the_policy_and_its_parameters(tmp_path: Path) -> None:
    venv = ChainCartVecEnv(2, seed=0, **CONFIG)
    model = PPO("MlpPolicy", venv, n_steps=32, batch_size=32, n_epochs=1, policy_kwargs=dict(net_arch=[16]),
                seed=0, device="cpu")  # fmt: skip
    model.learn(total_timesteps=64)
    observations = np.concatenate([venv.step(np.zeros((2, 1), np.float32))[0] for _ in range(5)])
    actions, _ = model.predict(observations, deterministic=True)
    params = copy.deepcopy(model.get_parameters())
    model.save(tmp_path / "ppo")
    loaded = PPO.load(tmp_path / "ppo", env=ChainCartVecEnv(2, seed=0, **CONFIG), device="cpu")
    np.testing.assert_array_equal(loaded.predict(observations, deterministic=True)[0], actions)
    for name, tensors in params.items():
        if "optim" in name:
            continue
        for key, value in tensors.items():
            assert np.array_equal(value.numpy(), loaded.get_parameters()[name][key].numpy()), (name, key)
    loaded.learn(total_timesteps=64, reset_num_timesteps=False)  # the loaded model trains on
    assert loaded.num_timesteps == 128


def test_vec_video_recorder_records_the_tiled_envs(tmp_path: Path) -> None:
    from stable_baselines3.common.vec_env import VecVideoRecorder

    venv = ChainCartVecEnv(2, seed=0, render_mode="rgb_array", render_width=48, render_height=24, **CONFIG)
    recorder = VecVideoRecorder(venv, str(tmp_path), record_video_trigger=lambda step: step == 0, video_length=10,
                                name_prefix="chain")  # fmt: skip
    recorder.reset()
    for _ in range(12):
        recorder.step(np.zeros((2, 1), np.float32))
    recorder.close()
    videos = list(tmp_path.glob("chain-step-0-to-step-10.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000


@pytest.mark.parametrize("make", [lambda: ChainCartVecEnv(N, **CONFIG), reference], ids=["native", "dummy"])
def test_a_scalar_action_is_a_type_error_like_dummy_vec_env(make: Any) -> None:
    venv = make()
    venv.reset()
    with pytest.raises(TypeError):
        venv.step(0)
