"""The real-rig keywords from Python: joint damping, cart friction and the actuation
modes (acceleration, voltage) through the config, gym.make, the vector env and the
command line; their checks, their defaults (the ideal model, bit for bit) and their
reproducibility."""

from __future__ import annotations

import pickle

import gymnasium as gym
import numpy as np
import pytest

from chaincart_env import ChainCartConfig, ChainCartEnv, ChainCartVectorEnv
from chaincart_env.errors import InvalidInputError

RIG = dict(
    joint_damping=[0.02, 0.01],
    cart_viscous_friction=0.5,
    cart_coulomb_friction=0.4,
    coulomb_velocity=0.02,
    obs_dtype="float64",
)
ZEROS = dict(joint_damping=0.0, cart_viscous_friction=0.0, cart_coulomb_friction=0.0, actuation="force")


def actions(step: int, num_envs: int) -> np.ndarray:
    return np.array([[np.sin(0.4 * step + 1.1 * i)] for i in range(num_envs)], dtype=np.float32)


def rollout(env: ChainCartEnv, seed: int, steps: int = 40) -> list[np.ndarray]:
    out = [env.reset(seed=seed)[0]]
    for step in range(steps):
        obs, reward, terminated, truncated, _ = env.step(actions(step, 1)[0])
        out.append(np.append(obs, reward))
        if terminated or truncated:
            out.append(env.reset()[0])
    return out


def test_the_defaults_are_the_ideal_model() -> None:
    c = ChainCartConfig()
    assert (c.joint_damping, c.cart_viscous_friction, c.cart_coulomb_friction) == (0.0, 0.0, 0.0)
    assert (c.actuation, c.coulomb_velocity, c.max_acceleration, c.max_voltage) == ("force", 0.01, 10.0, 12.0)
    assert c.motor == (0.02, 2.0, 5.0, 0.02, 5.0)
    assert not c.has_rig_effects and c.command_scale == c.max_force
    assert ChainCartConfig(**RIG).has_rig_effects
    assert ChainCartConfig(actuation="acceleration").command_scale == 10.0


def test_coefficients_of_zero_change_no_bit() -> None:
    for seed in (0, 7):
        a = rollout(ChainCartEnv(obs_dtype="float64"), seed)
        b = rollout(ChainCartEnv(obs_dtype="float64", **ZEROS), seed)
        assert len(a) == len(b)
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x, y)


def test_the_keys_round_trip_in_canonical_form() -> None:
    c = ChainCartConfig(joint_damping=[0.1, 0.2], motor={"resistance": 1.5}, actuation="voltage", max_voltage=6)
    assert c.joint_damping == (0.1, 0.2) and c.max_voltage == 6.0
    assert c.motor == (0.02, 1.5, 5.0, 0.02, 5.0)
    assert ChainCartConfig(motor=[0.03, 1.0, 4.0, 0.01, 3.0]).motor == (0.03, 1.0, 4.0, 0.01, 3.0)
    assert pickle.loads(pickle.dumps(c)) == c
    assert ChainCartConfig(**c.to_dict()) == c
    env = gym.make("ChainCart-v0", **RIG)
    again = gym.make(env.spec)
    assert again.unwrapped.config == env.unwrapped.config
    np.testing.assert_array_equal(again.reset(seed=2)[0], env.reset(seed=2)[0])


@pytest.mark.parametrize(
    "keywords, needle",
    [
        (dict(joint_damping=-0.1), "joint_damping[0] = -0.1: expected a finite number >= 0"),
        (dict(joint_damping=[0.1, 0.1, 0.1]), "joint_damping has length 3, expected 2"),
        (dict(joint_damping="much"), "joint_damping = 'much'"),
        (dict(cart_viscous_friction=-1.0), "cart_viscous_friction = -1: expected a finite number >= 0"),
        (dict(cart_coulomb_friction=float("nan")), "cart_coulomb_friction = NaN"),
        (dict(coulomb_velocity=0.0), "coulomb_velocity = 0: expected a finite number > 0"),
        (dict(actuation="torque"), '"force", "acceleration", "voltage"'),
        (dict(max_acceleration=-1.0), "max_acceleration = -1: expected a finite number >= 0"),
        (dict(max_voltage=float("inf")), "max_voltage = inf"),
        (dict(motor={"resistance": 0.0}), "motor.resistance = 0: expected a finite number > 0"),
        (dict(motor={"inductance": 1e-3}), "motor has unknown key 'inductance'"),
        (dict(motor=[1.0, 2.0]), "motor = [1.0, 2.0]"),
        (dict(actuation="acceleration", cart_coulomb_friction=1.0), "no cart friction"),
        (dict(joint_damping=0.1, integrator="variational"), 'integrator = "variational"'),
        (dict(cart_viscous_friction=0.1, precision="f32"), 'precision = "f32": expected "f64"'),
    ],
)
def test_bad_settings_raise_errors_naming_them(keywords: dict, needle: str) -> None:
    with pytest.raises(InvalidInputError) as e:
        ChainCartConfig(**keywords)
    assert needle in str(e.value)


def test_the_vector_env_is_n_single_envs_and_seeds_reproduce() -> None:
    num_envs = 4
    keywords = dict(RIG, actuation="voltage")
    vec = ChainCartVectorEnv(num_envs, **keywords)
    obs, _ = vec.reset(seed=40)
    singles = [ChainCartEnv(**keywords) for _ in range(num_envs)]
    for i, env in enumerate(singles):
        np.testing.assert_array_equal(env.reset(seed=40 + i)[0], obs[i])
    trace = []
    for step in range(30):
        a = actions(step, num_envs)
        obs, rewards, _, _, _ = vec.step(a)
        trace.append(obs.copy())
        for i, env in enumerate(singles):
            if env.unwrapped._needs_reset:
                continue  # the vector env autoresets on its next step
            o, r, _, _, _ = env.step(a[i])
            np.testing.assert_array_equal(o, obs[i], err_msg=f"env {i} step {step}")
            assert r == rewards[i]
    again = ChainCartVectorEnv(num_envs, **keywords)
    again.reset(seed=40)
    other = ChainCartVectorEnv(num_envs, **keywords)
    other.reset(seed=41)
    for step, expected in enumerate(trace):
        a = actions(step, num_envs)
        np.testing.assert_array_equal(again.step(a)[0], expected)
        assert not np.array_equal(other.step(a)[0], expected)


def test_the_rig_changes_the_motion() -> None:
    ideal = rollout(ChainCartEnv(obs_dtype="float64"), 3, steps=5)
    rigged = rollout(ChainCartEnv(**RIG), 3, steps=5)
    np.testing.assert_array_equal(ideal[0], rigged[0])  # the same start
    assert not np.array_equal(ideal[-1], rigged[-1])


def test_joint_damping_takes_energy_out_of_a_free_swing() -> None:
    def energies(**keywords: object) -> list[float]:
        env = ChainCartEnv(start="hanging", start_noise=0.3, max_force=0.0, diagnostics=True, **keywords)
        env.reset(seed=1)
        return [env.step(np.zeros(1))[4]["energy"] for _ in range(100)]

    # The joints take the links' swing energy (the cart's drift is not theirs to take).
    free, damped = energies(), energies(joint_damping=0.2)
    drift, lost = abs(free[-1] - free[0]), damped[0] - damped[-1]
    assert lost > 0.005 and lost > 100 * drift, (lost, drift)
    assert all(b <= a + 1e-12 for a, b in zip(damped, damped[1:]))


def test_an_acceleration_action_moves_the_cart_on_its_parabola() -> None:
    env = ChainCartEnv(actuation="acceleration", max_acceleration=4.0, start="hanging", start_noise=0.0, obs_dtype="float64")
    env.reset(seed=0)
    dt = env.unwrapped.config.dt
    obs = env.step(np.array([0.5]))[0]
    # x, xdot lead the planar observation: a = 0.5 * 4 m/s^2 for one period.
    assert obs[0] == pytest.approx(0.5 * 2.0 * dt**2, abs=1e-13)
    assert obs[1] == pytest.approx(2.0 * dt, abs=1e-13)


def test_the_command_line_takes_the_rig_keywords() -> None:
    import argparse

    from chaincart_env.tools.compare.scene_options import add_scene_options, config_from_options

    parser = argparse.ArgumentParser()
    add_scene_options(parser)
    assert "--joint-damping" in parser.format_help() and "--motor" in parser.format_help()
    args = parser.parse_args(
        ["--joint-damping", "0.1,0.2", "--actuation", "voltage", "--motor", '{"resistance": 1.0}', "--cart-coulomb-friction", "0.5"]
    )
    c = config_from_options(args)
    assert c.joint_damping == (0.1, 0.2) and c.actuation == "voltage"
    assert c.motor[1] == 1.0 and c.cart_coulomb_friction == 0.5


@pytest.mark.parametrize("cls", [ChainCartEnv, ChainCartVectorEnv])
def test_copies_mid_episode_continue_identically(cls: type) -> None:
    import copy

    keywords = dict(RIG, actuation="voltage")
    env = cls(**keywords) if cls is ChainCartEnv else cls(3, **keywords)
    n = 1 if cls is ChainCartEnv else 3
    env.reset(seed=9)
    for step in range(7):
        env.step(actions(step, n)[0] if n == 1 else actions(step, n))
    twin = copy.deepcopy(env)
    for step in range(7, 20):
        a = actions(step, n)[0] if n == 1 else actions(step, n)
        np.testing.assert_array_equal(env.step(a)[0], twin.step(a)[0])
