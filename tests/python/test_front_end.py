"""The one front end of the three env classes (``chaincart_env.front_end``): each class
takes the shared members from it instead of defining its own, the frameworks' methods
stay the frameworks', and over one seed the three classes run the same envs bit for bit."""

from __future__ import annotations

import inspect
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, VectorEnv
from stable_baselines3.common.vec_env import VecEnv

from chaincart_env import ChainCartEnv, ChainCartVecEnv, ChainCartVectorEnv, _core
from chaincart_env.front_end import BatchFrontEnd, EnvOfBatch, FrontEnd

CLASSES = (ChainCartEnv, ChainCartVectorEnv, ChainCartVecEnv)
FRAMEWORKS = {ChainCartEnv: gym.Env, ChainCartVectorEnv: VectorEnv, ChainCartVecEnv: VecEnv}

#: Some of what each part holds (the test checks all it defines).
EXPECTED = {
    FrontEnd: {"dt", "_open_batch", "_open_rendering", "_draw_step", "_rebuild_batch", "__getstate__", "__setstate__"},
    BatchFrontEnd: {"episode_targets", "_open_tiled_rendering"},
    EnvOfBatch: {"state", "model_state", "elapsed_steps", "episode_target", "true_params", "set_state"},
}
#: Front-end hooks a class extends (its own version calls the front end's).
EXTENDED = {(ChainCartVectorEnv, "_show_frame")}  # rgb_array_list also keeps every frame


def shared_members(part: type) -> dict[str, Any]:
    """The methods and properties ``part`` of the front end defines."""
    return {name: value for name, value in vars(part).items() if callable(value) or isinstance(value, property)}


@pytest.mark.parametrize("part", [FrontEnd, BatchFrontEnd, EnvOfBatch])
def test_every_class_built_on_a_front_end_part_takes_its_members_from_it(part: type) -> None:
    users = [cls for cls in CLASSES if issubclass(cls, part)]
    assert users, part
    members = shared_members(part)
    assert EXPECTED[part] <= set(members), members
    for cls in users:
        for name, member in members.items():
            if (cls, name) in EXTENDED:
                assert name in vars(cls)
                continue
            # The member the class resolves is the front end's object itself: neither the
            # class nor anything before the front end in its MRO redefines it.
            assert inspect.getattr_static(cls, name) is member, f"{cls.__name__}.{name}"


def test_which_classes_share_which_parts() -> None:
    assert all(issubclass(cls, FrontEnd) for cls in CLASSES)
    assert [cls for cls in CLASSES if issubclass(cls, BatchFrontEnd)] == [ChainCartVectorEnv, ChainCartVecEnv]
    assert [cls for cls in CLASSES if issubclass(cls, EnvOfBatch)] == [ChainCartEnv]
    venv = ChainCartVecEnv(2, n_links=2)
    assert all(isinstance(view, EnvOfBatch) for view in venv._views)  # SB3's per-env views


@pytest.mark.parametrize("cls", CLASSES)
def test_the_frameworks_methods_stay_the_frameworks(cls: type) -> None:
    framework = FRAMEWORKS[cls]
    assert issubclass(cls, framework)
    # The front end comes before the framework's class and defines none of its methods,
    # so it shadows nothing of the framework's API.
    mro = cls.__mro__
    assert mro.index(FrontEnd) < mro.index(framework)
    framework_members = set().union(*(shared_members(base) for base in (gym.Env, VectorEnv, VecEnv)))
    for part in (FrontEnd, BatchFrontEnd, EnvOfBatch):
        assert set(shared_members(part)) & framework_members == set(), part
    for name in ("__init__", "reset", "render", "close"):
        assert not any(name in vars(part) for part in (FrontEnd, BatchFrontEnd, EnvOfBatch)), name


# Each scene with short episodes that end; swing-up with every per-episode draw (parameters,
# sensor noise and a delay of 0-2 periods).
SCENES = {
    "inverted-2": dict(scene="inverted-2"),
    "swingup-2 (randomized, noisy, delayed)": dict(
        scene="swingup-2", randomize={"link_masses": 0.2, "link_lengths": 0.1}, obs_noise=0.01, action_delay=(0, 2)
    ),
    "spatial-inverted-2": dict(scene="spatial-inverted-2"),
    "transitions-2": dict(scene="transitions-2"),
}
N = 3
SEED = 77
STEPS = 40


def single_env_runs(config: dict[str, Any], actions: np.ndarray) -> list[list[dict[str, Any]]]:
    """Per env i, what each step must show: the single env seeded ``SEED + i``, reset
    without a seed when an episode ends (same-step autoreset)."""
    runs = []
    for i in range(N):
        env = ChainCartEnv(**config)
        env.reset(seed=SEED + i)
        records = []
        for a in actions[:, i]:
            obs, reward, terminated, truncated, info = env.step(a)
            record = dict(obs=obs, reward=reward, terminated=terminated, truncated=truncated, end=None)
            if terminated or truncated:
                record["end"], record["final_obs"] = info, obs
                record["obs"], _ = env.reset()
            record.update(state=env.state, params=env.true_params, target=env.episode_target)
            records.append(record)
        runs.append(records)
    return runs


@pytest.mark.parametrize("scene", list(SCENES))
def test_a_seeded_rollout_is_the_same_in_the_env_the_vector_env_and_the_sb3_vec_env(scene: str) -> None:
    config = dict(SCENES[scene], max_episode_steps=12)
    force_dim = ChainCartEnv(**config).action_space.shape[0]
    actions = np.random.default_rng(5).uniform(-1.2, 1.2, (STEPS, N, force_dim)).astype(np.float32)
    want = single_env_runs(config, actions)

    vector = ChainCartVectorEnv(N, autoreset_mode=AutoresetMode.SAME_STEP, **config)
    sb3 = ChainCartVecEnv(N, seed=SEED, **config)
    v_obs, _ = vector.reset(seed=SEED)
    assert np.array_equal(sb3.reset(), v_obs)
    ends = 0
    for k, a in enumerate(actions):
        v_obs, v_rewards, v_terminated, v_truncated, v_info = vector.step(a)
        s_obs, s_rewards, s_dones, s_infos = sb3.step(a)
        v_params = vector.true_params
        for i in range(N):
            w, where = want[i][k], f"{scene}: env {i}, step {k}"
            assert np.array_equal(v_obs[i], w["obs"]) and np.array_equal(s_obs[i], w["obs"]), where
            assert v_rewards[i] == w["reward"] and s_rewards[i] == np.float32(w["reward"]), where
            assert (v_terminated[i], v_truncated[i]) == (w["terminated"], w["truncated"]), where
            assert s_dones[i] == (w["terminated"] or w["truncated"]), where
            assert np.array_equal(vector.states[i], w["state"]), where
            assert np.array_equal(sb3.get_attr("state", i)[0], w["state"]), where
            assert tuple(vector.episode_targets[i]) == w["target"] == sb3.get_attr("episode_target", i)[0], where
            s_params = sb3.get_attr("true_params", i)[0]
            for key, value in w["params"].items():
                assert np.array_equal(v_params[key][i], value) and np.array_equal(s_params[key], value), where
            if w["end"] is None:
                assert not v_info.get("_final_obs", np.zeros(N, bool))[i] and "terminal_observation" not in s_infos[i]
                continue
            ends += 1
            assert np.array_equal(v_info["final_obs"][i], w["final_obs"]), where
            assert np.array_equal(s_infos[i]["terminal_observation"], w["final_obs"]), where
            for key, value in w["end"].items():
                assert v_info["final_info"][key][i] == value and s_infos[i][key] == value, (where, key)
    assert ends >= N  # every env ended an episode, its next one started by the autoreset
    assert vector._batch is not sb3._batch and isinstance(sb3._batch, _core.EnvBatch)
