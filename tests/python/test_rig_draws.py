"""Joint damping and cart friction drawn per episode (``randomize``'s rig entries):
each episode's draw is reported and is the system it steps, reproducible under a seed,
the same in a vector env as alone, kept by copies, and checked with clear errors."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from chaincart_env import ChainCartEnv, ChainCartVectorEnv, InvalidInputError

DRAWS = {
    "joint_damping": {"range": [0.0, 0.03]},
    "cart_viscous_friction": {"range": [0.1, 0.5]},
    "cart_coulomb_friction": {"range": [0.0, 1.0]},
}
KEYWORDS = dict(randomize=DRAWS, obs_dtype="float64", start_noise=0.1)


def _actions(step: int, num_envs: int) -> np.ndarray:
    return np.array([[np.sin(0.4 * step + 1.1 * i)] for i in range(num_envs)])


def test_each_episode_reports_its_own_draw_within_the_ranges() -> None:
    env = ChainCartEnv(**KEYWORDS)
    draws = []
    for seed in range(30):
        _, info = env.reset(seed=seed)
        params = info["params"]
        assert len(params["joint_damping"]) == 2
        assert all(0.0 <= c < 0.03 for c in params["joint_damping"])
        assert 0.1 <= params["cart_viscous_friction"] < 0.5
        assert 0.0 <= params["cart_coulomb_friction"] < 1.0
        assert params == env.unwrapped.true_params
        draws.append(params["cart_coulomb_friction"])
    assert len(set(draws)) == 30
    # Shared across links on request.
    shared = ChainCartEnv(randomize={"joint_damping": {"range": [0.01, 0.02], "per_link": False}})
    first, second = shared.reset(seed=0)[1]["params"]["joint_damping"]
    assert first == second


def test_an_episode_steps_as_the_fixed_rig_it_drew() -> None:
    drawn = ChainCartEnv(**KEYWORDS)
    obs, info = drawn.reset(seed=5)
    rig = {key: info["params"][key] for key in DRAWS}
    fixed = ChainCartEnv(**dict(KEYWORDS, randomize=None, start=obs.tolist(), start_noise=0.0), **rig)
    np.testing.assert_array_equal(fixed.reset(seed=0)[0], obs)
    for step in range(40):
        a = _actions(step, 1)[0].astype(np.float32)
        np.testing.assert_array_equal(drawn.step(a)[0], fixed.step(a)[0], err_msg=f"step {step}")


def test_the_vector_env_is_n_single_envs_and_reports_every_draw() -> None:
    num_envs = 3
    vec = ChainCartVectorEnv(num_envs, **KEYWORDS)
    obs, info = vec.reset(seed=20)
    assert info["params"]["joint_damping"].shape == (num_envs, 2)
    assert info["params"]["cart_coulomb_friction"].shape == (num_envs,)
    singles = [ChainCartEnv(**KEYWORDS) for _ in range(num_envs)]
    for i, env in enumerate(singles):
        single_obs, single_info = env.reset(seed=20 + i)
        np.testing.assert_array_equal(single_obs, obs[i])
        np.testing.assert_array_equal(single_info["params"]["joint_damping"], info["params"]["joint_damping"][i])
    for step in range(30):
        a = _actions(step, num_envs).astype(np.float32)
        obs, *_ = vec.step(a)
        for i, env in enumerate(singles):
            np.testing.assert_array_equal(env.step(a[i])[0], obs[i], err_msg=f"env {i} step {step}")


def test_a_copy_mid_episode_keeps_the_draws() -> None:
    env = ChainCartVectorEnv(4, **KEYWORDS)
    env.reset(seed=2)
    for step in range(5):
        env.step(_actions(step, 4).astype(np.float32))
    twin = copy.deepcopy(env)
    np.testing.assert_array_equal(twin.true_params["cart_coulomb_friction"], env.true_params["cart_coulomb_friction"])
    for step in range(5, 60):
        a = _actions(step, 4).astype(np.float32)
        np.testing.assert_array_equal(env.step(a)[0], twin.step(a)[0])


@pytest.mark.parametrize(
    "randomize, needle",
    [
        ({"joint_damping": 0.5}, "randomize.joint_damping = 0: expected a relative draw of a non-zero value"),
        ({"cart_coulomb_friction": {"range": [-1.0, 1.0]}}, "range [-1, 1]: expected 0 <= low <= high"),
        ({"joint_dampng": {"range": [0, 1]}}, 'did you mean "joint_damping"'),
    ],
)
def test_bad_draws_raise_errors_naming_them(randomize: dict, needle: str) -> None:
    with pytest.raises(InvalidInputError, match=None) as error:
        ChainCartEnv(randomize=randomize)
    assert needle in str(error.value)
