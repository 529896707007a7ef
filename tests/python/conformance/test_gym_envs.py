"""Gymnasium's generic env tests (tests/envs: env checker, passive checker,
determinism, pickling, spec and registration) on ChainCart-v0."""

from __future__ import annotations

import json
import pickle
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from conformance_support import CONFIGS, clean_environ, unexpected_warnings
from gymnasium.envs.registration import EnvSpec
from gymnasium.utils.env_checker import check_env, data_equivalence

import chaincart_env
from chaincart_env import SCENES, ChainCartConfig, ChainCartEnv, RewardWeights

HEADLESS_WARNING = ("human-mode frames are not shown",)


@pytest.mark.parametrize("name", CONFIGS)
def test_check_env_with_defaults_passes_headless(name: str, headless: None) -> None:
    # With a spec (gymnasium.make) the checker also makes the env in every render
    # mode, human included: on a machine without a display that must only warn.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env = gym.make("ChainCart-v0", **CONFIGS[name]).unwrapped
        check_env(env)
        env.close()
    assert unexpected_warnings(caught, HEADLESS_WARNING) == []
    assert sum(HEADLESS_WARNING[0] in str(w.message) for w in caught) == 1


def test_check_env_with_defaults_passes_on_the_class_and_rgb_array(headless: None) -> None:
    for env in (ChainCartEnv(), ChainCartEnv(render_mode="rgb_array", render_width=64, render_height=32)):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check_env(env)
        # Without a spec the checker says it cannot try the other render modes.
        assert unexpected_warnings(caught, ("Not able to test alternative render modes",)) == []


@pytest.mark.parametrize("name", CONFIGS)
def test_passive_env_checker_raises_no_warning(name: str) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env = gym.make("ChainCart-v0", **CONFIGS[name])
        env.reset(seed=0)
        env.step(env.action_space.sample())
        env.close()
    assert unexpected_warnings(caught) == []


@pytest.mark.parametrize("name", CONFIGS)
def test_rollouts_of_two_envs_seeded_alike_are_identical(name: str) -> None:
    env_1 = gym.make("ChainCart-v0", disable_env_checker=True, **CONFIGS[name])
    env_2 = gym.make("ChainCart-v0", disable_env_checker=True, **CONFIGS[name])
    obs_1, info_1 = env_1.reset(seed=0)
    obs_2, info_2 = env_2.reset(seed=0)
    assert data_equivalence(obs_1, obs_2, exact=True) and data_equivalence(info_1, info_2, exact=True)
    env_1.action_space.seed(0)
    for _ in range(50):
        action = env_1.action_space.sample()
        step_1, step_2 = env_1.step(action), env_2.step(action)
        assert data_equivalence(step_1, step_2, exact=True)
        assert step_1[0] in env_1.observation_space
        if step_1[2] or step_1[3]:
            env_1.reset(seed=0)
            env_2.reset(seed=0)


@pytest.mark.parametrize("name", CONFIGS)
def test_a_pickled_env_resets_and_steps_like_the_original(name: str) -> None:
    env = gym.make("ChainCart-v0", **CONFIGS[name])
    action = env.action_space.sample()
    reset, step = env.reset(seed=123), env.step(action)
    clone = pickle.loads(pickle.dumps(env))
    assert data_equivalence(reset, clone.reset(seed=123)) and data_equivalence(step, clone.step(action))


def test_registration_has_the_default_scenes_episode_length() -> None:
    length = SCENES["inverted-2"]["max_episode_steps"]
    assert gym.spec("ChainCart-v0").max_episode_steps == length == 500
    env = gym.make("ChainCart-v0")
    assert env.spec.max_episode_steps == length
    assert any(isinstance(w, gym.wrappers.TimeLimit) for w in _wrappers(env))
    env.reset(seed=1)
    steps = 0
    while True:
        steps += 1
        _, _, terminated, truncated, info = env.step(np.zeros(1, np.float32))
        if terminated or truncated:
            break
    # The LQR-free zero force lets the double pendulum fall: either the track limit
    # ends it early, or the episode runs exactly the registered length.
    assert steps <= length and (terminated or steps == length)
    assert "is_success" in info


def _wrappers(env: gym.Env) -> list[gym.Env]:
    out = []
    while isinstance(env, gym.Wrapper):
        out.append(env)
        env = env.env
    return out


def test_spec_reading_wrappers_work_on_a_plain_make() -> None:
    env = gym.wrappers.TimeAwareObservation(gym.make("ChainCart-v0"))
    obs, _ = env.reset(seed=0)
    assert obs.shape == (9,) and obs[-1] == 0 and obs in env.observation_space
    obs, *_ = env.step(np.zeros(1, np.float32))
    assert obs[-1] == 1
    stats = gym.wrappers.RecordEpisodeStatistics(gym.make("ChainCart-v0", track_limit=0.05, start_noise=0.0))
    stats.reset(seed=0)
    done, info = False, {}
    while not done:
        _, _, terminated, truncated, info = stats.step(np.ones(1, np.float32))
        done = terminated or truncated
    assert info["episode"]["l"] >= 1 and info["episode"]["r"] > 0


def test_make_vec_keeps_a_scenes_own_length() -> None:
    # make_vec passes the registered length (500) to the vector env unless given one;
    # that default does not cut a chosen scene, while an explicit length is kept.
    make = lambda **kw: gym.make_vec("ChainCart-v0", 2, vectorization_mode="vector_entry_point", **kw)  # noqa: E731
    assert make(scene="paper-fig3").unwrapped.config.max_episode_steps == 12_000
    assert make(config={"max_episode_steps": 30}).unwrapped.config.max_episode_steps == 30
    assert make().unwrapped.config.max_episode_steps == 500
    assert make(scene="paper-fig3", max_episode_steps=77).unwrapped.config.max_episode_steps == 77


def test_a_scenes_own_length_applies_through_make_with_its_length() -> None:
    # gymnasium.make wraps every id in the TimeLimit of its registration unless told
    # otherwise; passing the scene's length (or -1: no TimeLimit) keeps the scene's.
    config = ChainCartConfig(scene="paper-fig3")
    env = gym.make("ChainCart-v0", scene="paper-fig3", max_episode_steps=config.max_episode_steps)
    assert env.spec.max_episode_steps == env.unwrapped.config.max_episode_steps == 12_000
    unlimited = gym.make("ChainCart-v0", scene="paper-fig3", max_episode_steps=-1)
    assert not any(isinstance(w, gym.wrappers.TimeLimit) for w in _wrappers(unlimited))
    assert unlimited.unwrapped.config.max_episode_steps == 12_000
    assert ChainCartEnv(scene="paper-fig3").config.max_episode_steps == 12_000


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_every_scene_has_an_id_registered_with_its_own_length(scene: str) -> None:
    env_id = chaincart_env.scene_env_id(scene)
    length = SCENES[scene]["max_episode_steps"]
    assert gym.spec(env_id).max_episode_steps == length
    env = gym.make(env_id)
    limits = [w for w in _wrappers(env) if isinstance(w, gym.wrappers.TimeLimit)]
    assert [w._max_episode_steps for w in limits] == [length]
    assert env.spec.max_episode_steps == env.unwrapped.config.max_episode_steps == length
    assert env.unwrapped.config == ChainCartConfig(scene=scene)
    vec = gym.make_vec(env_id, 2, vectorization_mode="vector_entry_point")
    assert vec.unwrapped.config == ChainCartConfig(scene=scene)


def test_a_scene_id_runs_the_scene_past_the_default_length() -> None:
    # The default scene's 500 steps would cut Fig. 3's 12 000-step episode; its own
    # id's TimeLimit lets it run on, and keywords still change the rest.
    env = gym.make("ChainCart-paper-fig3-v0", start_noise=0.01)
    assert env.unwrapped.config.start_noise == 0.01
    env.reset(seed=0)
    zero = np.zeros(2, np.float32)
    for _ in range(600):
        _, _, terminated, truncated, _ = env.step(zero)
        assert not (terminated or truncated)
    assert gym.spec(chaincart_env.ENV_ID).max_episode_steps == 500


DOCUMENTED_WAYS = {
    "nothing": {},
    "scene": dict(scene="paper-fig2"),
    "keywords": dict(n_links=3, planar=False, target=(1, -1, 1), start="hanging", start_noise=0.1,
                     reward_weights={"x": 0.0}, success_tolerances=(0.2, 0.4), integrator="rkmk4"),
    "reward weights object": dict(reward_weights=RewardWeights(u=0.5)),
    "array start": dict(scene="inverted-1", start=np.array([0.1, 0.0, 0.0, -1.0, 0.0])),
    "config object": dict(config=ChainCartConfig(scene="swingup-1", max_episode_steps=77)),
    "config dict (episode length as plain JSON)": dict(config={"max_episode_steps": 123, "dt": 0.01}),
    "render keywords": dict(render_mode="rgb_array", render_width=64, render_height=32),
}  # fmt: skip


@pytest.mark.parametrize("way", DOCUMENTED_WAYS)
def test_spec_to_json_round_trips(way: str) -> None:
    env = gym.make("ChainCart-v0", **DOCUMENTED_WAYS[way])
    text = env.spec.to_json()
    json.loads(text)  # plain JSON
    remade = gym.make(EnvSpec.from_json(text))
    assert remade.unwrapped.config == env.unwrapped.config
    assert remade.spec == env.spec and remade.render_mode == env.render_mode
    obs, _ = env.reset(seed=5)
    assert np.array_equal(remade.reset(seed=5)[0], obs)


def test_vector_spec_to_json_round_trips() -> None:
    envs = gym.make_vec("ChainCart-v0", 3, vectorization_mode="vector_entry_point",
                        config=ChainCartConfig(n_links=3, max_episode_steps=9))  # fmt: skip
    text = envs.spec.to_json()
    remade = gym.make_vec(EnvSpec.from_json(text))
    assert remade.unwrapped.config == envs.unwrapped.config and remade.num_envs == 3


def test_the_module_qualified_id_imports_the_package() -> None:
    # What SubprocVecEnv with spawn/forkserver (or any process that never imported
    # chaincart_env) needs: "module:Id" imports the module, which registers the id.
    code = (
        "import sys, gymnasium as gym\n"
        "assert 'chaincart_env' not in sys.modules\n"
        "env = gym.make('chaincart_env:ChainCart-v0')\n"
        "print(env.spec.id, env.spec.max_episode_steps, env.reset(seed=0)[0].shape)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=clean_environ_with_path())
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["ChainCart-v0", "500", "(8,)"]


def test_subproc_vec_env_with_spawn_uses_the_module_qualified_id() -> None:
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import SubprocVecEnv

    venv = make_vec_env("chaincart_env:ChainCart-v0", n_envs=2, seed=3, vec_env_cls=SubprocVecEnv,
                        vec_env_kwargs={"start_method": "spawn"}, env_kwargs={"scene": "inverted-1"})  # fmt: skip
    try:
        obs = venv.reset()
        single = ChainCartEnv(scene="inverted-1")
        assert np.array_equal(obs[1], single.reset(seed=4)[0])
    finally:
        venv.close()


def clean_environ_with_path() -> dict[str, str]:
    """The child sees the same chaincart_env as this process, and nothing imported."""
    env = clean_environ()
    env["PYTHONPATH"] = str(__import__("pathlib").Path(chaincart_env.__file__).parents[1])
    return env
