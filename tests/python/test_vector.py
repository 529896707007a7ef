"""The native Gymnasium vector env: autoreset modes, single-vs-vector equivalence,
batched infos, bad actions, copies."""

from __future__ import annotations

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

from chaincart_env import ChainCartEnv, ChainCartError, ChainCartVectorEnv

# Short episodes that end every way (track, fall and time limit), several chunks of envs.
CONFIG = dict(n_links=2, start_noise=0.25, max_episode_steps=15, track_limit=0.3, max_force=20.0, fall_limit=0.6)
N = 37
SEED = 1000
STEPS = 45


def actions_for(n: int, steps: int = STEPS) -> np.ndarray:
    return np.random.default_rng(7).uniform(-1.2, 1.2, (steps, n, 1)).astype(np.float32)


def single_run(env_index: int, mode: AutoresetMode) -> list[dict]:
    """What env ``env_index`` of the vector env must show, built from a single env."""
    env = ChainCartEnv(**CONFIG)
    obs, _ = env.reset(seed=SEED + env_index)
    acts = actions_for(N)[:, env_index]
    records, pending_reset = [], False
    for a in acts:
        if pending_reset and mode == AutoresetMode.NEXT_STEP:
            obs, _ = env.reset()
            records.append(dict(obs=obs, reward=0.0, terminated=False, truncated=False, end=None))
            pending_reset = False
            continue
        obs, reward, terminated, truncated, info = env.step(a)
        rec = dict(obs=obs, reward=reward, terminated=terminated, truncated=truncated, end=None)
        if terminated or truncated:
            rec["end"] = info
            if mode == AutoresetMode.SAME_STEP:
                rec["final_obs"] = obs
                rec["obs"], _ = env.reset()
            elif mode == AutoresetMode.DISABLED:
                rec["after_reset"], _ = env.reset()
            else:
                pending_reset = True
        records.append(rec)
    return records


def vector_run(mode: AutoresetMode) -> tuple[np.ndarray, list[dict]]:
    envs = gym.make_vec(
        "ChainCart-v0", num_envs=N, vectorization_mode="vector_entry_point", autoreset_mode=mode, **CONFIG
    )
    assert isinstance(envs.unwrapped, ChainCartVectorEnv)
    assert envs.metadata["autoreset_mode"] == mode
    obs0, info0 = envs.reset(seed=SEED)
    assert info0 == {}
    steps = []
    for a in actions_for(N):
        obs, rewards, terminated, truncated, info = envs.step(a)
        step = dict(obs=obs, rewards=rewards, terminated=terminated, truncated=truncated, info=info)
        if mode == AutoresetMode.DISABLED:
            ended = terminated | truncated
            if ended.any():
                step["after_reset"], _ = envs.reset(options={"reset_mask": ended})
        steps.append(step)
    return obs0, steps


def check_episode_info(info: dict, i: int, expected: dict) -> None:
    for key, value in expected.items():
        assert info["_" + key][i], key
        assert info[key][i] == value, (key, info[key][i], value)


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP, AutoresetMode.DISABLED])
def test_env_i_of_the_vector_env_is_the_single_env_seeded_seed_plus_i(mode: AutoresetMode) -> None:
    obs0, steps = vector_run(mode)
    episode_ends = falls = 0
    for i in range(N):
        assert np.array_equal(obs0[i], ChainCartEnv(**CONFIG).reset(seed=SEED + i)[0])
        for k, (want, got) in enumerate(zip(single_run(i, mode), steps)):
            where = f"env {i}, step {k}, {mode}"
            assert np.array_equal(got["obs"][i], want["obs"]), where
            assert got["rewards"][i] == want["reward"], where
            assert got["terminated"][i] == want["terminated"], where
            assert got["truncated"][i] == want["truncated"], where
            info = got["info"]
            if want["end"] is None:
                for mask in ("_is_success", "_final_obs"):
                    assert mask not in info or not info[mask][i], where
                continue
            episode_ends += 1
            falls += want["end"]["fell"]
            if mode == AutoresetMode.SAME_STEP:
                assert info["_final_obs"][i] and info["_final_info"][i]
                assert np.array_equal(info["final_obs"][i], want["final_obs"]), where
                check_episode_info(info["final_info"], i, want["end"])
            else:
                check_episode_info(info, i, want["end"])
            if mode == AutoresetMode.DISABLED:
                assert np.array_equal(got["after_reset"][i], want["after_reset"]), where
    assert episode_ends > N  # every env ended at least once, most several times
    assert 0 < falls < episode_ends


def test_infos_are_empty_while_nothing_ends_and_batched_when_something_does() -> None:
    envs = ChainCartVectorEnv(4, start_noise=0.0, max_episode_steps=2)
    envs.reset(seed=0)
    _, _, _, _, info = envs.step(np.zeros((4, 1), np.float32))
    assert info == {}
    obs, rewards, terminated, truncated, info = envs.step(np.zeros((4, 1), np.float32))
    assert truncated.all() and not terminated.any() and rewards.dtype == np.float64
    assert set(info) == {
        "is_success", "_is_success", "numerical_failure", "_numerical_failure",
        "out_of_track", "_out_of_track", "fell", "_fell", "e_q", "_e_q", "e_w", "_e_w",
    }  # fmt: skip
    assert info["is_success"].all() and info["_is_success"].all()
    # Next step: the reset step.
    obs2, rewards, terminated, truncated, info = envs.step(np.ones((4, 1), np.float32))
    assert (rewards == 0).all() and not (terminated | truncated).any() and info == {}
    assert np.array_equal(envs.elapsed_steps, np.zeros(4))


def test_spaces_and_dtypes() -> None:
    envs = ChainCartVectorEnv(8, n_links=3, planar=False, obs_dtype="float64")
    assert envs.single_observation_space.shape == (22,) and envs.single_action_space.shape == (2,)
    assert envs.observation_space.shape == (8, 22) and envs.action_space.shape == (8, 2)
    obs, _ = envs.reset(seed=1)
    assert obs.dtype == np.float64 and obs in envs.observation_space
    obs, rewards, terminated, truncated, _ = envs.step(envs.action_space.sample())
    assert obs in envs.observation_space
    assert rewards.shape == terminated.shape == truncated.shape == (8,)
    assert terminated.dtype == truncated.dtype == np.bool_
    assert envs.states.shape == (8, 22) and envs.dt == 0.02


def test_a_bad_action_in_one_env_changes_no_env() -> None:
    envs = ChainCartVectorEnv(40, n_links=2, start_noise=0.2)
    envs.reset(seed=3)
    envs.step(np.full((40, 1), 0.3, np.float32))
    states, counts = envs.model_states, envs.elapsed_steps
    bad = np.zeros((40, 1), np.float32)
    bad[33, 0] = np.nan
    with pytest.raises(ChainCartError, match=r"actions\[33, 0\] = NaN: expected a finite number \(env 33, component 0\)"):
        envs.step(bad)
    bad[33, 0] = -np.inf
    with pytest.raises(ChainCartError, match="= -inf"):
        envs.step(bad)
    with pytest.raises(ChainCartError, match=r"actions has shape \(39, 1\), expected \(40, 1\)"):
        envs.step(np.zeros((39, 1), np.float32))
    with pytest.raises(ChainCartError, match=r"actions has shape \(40,\), expected \(40, 1\)"):
        envs.step(np.zeros(40))
    assert np.array_equal(envs.model_states, states) and np.array_equal(envs.elapsed_steps, counts)


def test_disabled_mode_refuses_ended_envs_until_reset() -> None:
    envs = ChainCartVectorEnv(3, autoreset_mode="disabled", max_episode_steps=1)
    envs.reset(seed=0)
    envs.step(np.zeros((3, 1), np.float32))
    with pytest.raises(ChainCartError, match="reset_mask"):
        envs.step(np.zeros((3, 1), np.float32))
    with pytest.raises(ChainCartError, match="reset_mask"):
        envs.reset(options={"reset_mask": np.zeros(3, bool)})
    with pytest.raises(ChainCartError, match="reset_mask"):
        envs.reset(options={"reset_mask": [True, True, True]})
    keep = envs.model_states[1]
    obs, _ = envs.reset(options={"reset_mask": np.array([True, False, True])})
    assert np.array_equal(obs[1], keep.astype(np.float32))
    with pytest.raises(ChainCartError):
        envs.step(np.zeros((3, 1), np.float32))  # env 1 still ended
    envs.reset(options={"reset_mask": np.array([False, True, False])})
    envs.step(np.zeros((3, 1), np.float32))


def test_seed_lists_and_unseeded_resets() -> None:
    envs = ChainCartVectorEnv(3, n_links=2, start_noise=0.2)
    obs, _ = envs.reset(seed=[5, None, 9])
    assert np.array_equal(obs[0], ChainCartEnv(n_links=2, start_noise=0.2).reset(seed=5)[0])
    assert np.array_equal(obs[2], ChainCartEnv(n_links=2, start_noise=0.2).reset(seed=9)[0])
    with pytest.raises(ChainCartError, match="seed has 2 entries"):
        envs.reset(seed=[1, 2])
    with pytest.raises(ChainCartError, match="seed = -1"):
        envs.reset(seed=-1)
    # Unseeded vector envs draw fresh entropy: two of them start differently.
    a, _ = ChainCartVectorEnv(3, n_links=2, start_noise=0.2).reset()
    b, _ = ChainCartVectorEnv(3, n_links=2, start_noise=0.2).reset()
    assert not np.array_equal(a, b)


def test_numerical_failure_in_one_env_leaves_the_others_running() -> None:
    envs = ChainCartVectorEnv(
        4, n_links=2, planar=False, integrator="lie_euler", dt=2.0, max_force=1e6, track_limit=1e300,
        start_noise=0.3, autoreset_mode="same_step",
    )  # fmt: skip
    envs.reset(seed=0)
    actions = np.zeros((4, 2), np.float32)
    actions[2] = [1.0, -1.0]  # only env 2 is pushed hard
    failed = False
    for _ in range(30):
        obs, rewards, terminated, truncated, info = envs.step(actions)
        assert np.all(np.isfinite(obs))
        if "final_info" in info and info["final_info"]["numerical_failure"].any():
            failed = True
            assert info["final_info"]["numerical_failure"][2] and terminated[2] and rewards[2] == 0.0
            assert np.all(np.isfinite(info["final_obs"][2]))
            break
    assert failed


def test_diagnostics_are_batched_for_every_env() -> None:
    envs = ChainCartVectorEnv(5, n_links=2, diagnostics=True, obs_dtype="float64")
    envs.reset(seed=0)
    _, _, _, _, info = envs.step(np.zeros((5, 1), np.float32))
    model, states = envs.model, envs.model_states
    assert info["_energy"].all()
    assert np.allclose(info["energy"], [model.energy(y) for y in states], rtol=1e-14)
    assert np.allclose(info["e_q"], [model.errors(y, "inverted")[0] for y in states], rtol=1e-14)


@pytest.mark.parametrize("clone", [copy.deepcopy, lambda e: pickle.loads(pickle.dumps(e))])
def test_copies_mid_episode_continue_identically(clone) -> None:
    envs = ChainCartVectorEnv(35, autoreset_mode="same_step", **CONFIG)
    envs.reset(seed=2)
    acts = actions_for(35, 40)
    for a in acts[:10]:
        envs.step(a)
    twin = clone(envs)
    for a in acts[10:]:
        x, y = envs.step(a), twin.step(a)
        for u, v in zip(x[:4], y[:4]):
            assert np.array_equal(u, v)
        assert x[4].keys() == y[4].keys()
