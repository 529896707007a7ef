"""Encoders from Python: angle and cart encoders quantise the observed positions onto
their grids, the velocities are the finite differences of the readings (optionally
low-pass filtered), and with the encoders off the observations are the ones the env
gave before encoders existed, bit for bit."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from chaincart_env import ChainCartConfig, ChainCartEnv, ChainCartVectorEnv
from chaincart_env.errors import InvalidInputError, InvalidTypeError

ANGLE_COUNTS = 4096
CART_COUNTS = 2500.0
ENCODERS = dict(angle_encoder_counts=ANGLE_COUNTS, cart_encoder_counts=CART_COUNTS, obs_dtype="float64")
BEFORE = Path(__file__).parent / "data" / "obs_before_encoders.npz"


def actions(step: int, num_envs: int, force_dim: int) -> np.ndarray:
    a = [[np.sin(0.4 * step + 1.1 * i + 0.7 * k) for k in range(force_dim)] for i in range(num_envs)]
    return np.array(a, dtype=np.float32)


def single_rollout(env: ChainCartEnv, seed: int, steps: int) -> tuple[list[np.ndarray], list[bool]]:
    """Observations and whether each is an episode's first."""
    obs = [env.reset(seed=seed)[0]]
    first = [True]
    force_dim = env.action_space.shape[0]
    for step in range(steps):
        o, _, terminated, truncated, _ = env.step(actions(step, 1, force_dim)[0])
        obs.append(o)
        first.append(False)
        if terminated or truncated:
            obs.append(env.reset()[0])
            first.append(True)
    return obs, first


def parts(config: ChainCartConfig, obs: np.ndarray) -> dict[str, np.ndarray]:
    return {name: obs[start:stop] for name, (start, stop) in config.state_layout.items()}


def link_angles(config: ChainCartConfig, obs: np.ndarray) -> np.ndarray:
    """Planar: each link's angle atan2(q1, q3), shape (n, 1). Spatial: swing and tilt
    of q = (cos phi sin theta, -sin phi, cos phi cos theta), shape (n, 2)."""
    q = parts(config, obs)["q"].reshape(config.n_links, -1)
    if config.planar:
        return np.arctan2(q[:, 0], q[:, 1])[:, None]
    return np.stack([np.arctan2(q[:, 0], q[:, 2]), np.arctan2(-q[:, 1], np.hypot(q[:, 0], q[:, 2]))], axis=1)


def wrapped(d: np.ndarray) -> np.ndarray:
    return (d + np.pi) % (2 * np.pi) - np.pi


def spins(config: ChainCartConfig, angles: np.ndarray, rates: np.ndarray) -> np.ndarray:
    """The links' angular velocities of angle rates at these angles: planar the rate
    itself; spatial the gimbal frame's omega = theta' e2 + phi' R_y(theta) e1 less its
    part along q."""
    if config.planar:
        return rates[:, 0]
    theta, phi = angles[:, 0], angles[:, 1]
    q = np.stack([np.cos(phi) * np.sin(theta), -np.sin(phi), np.cos(phi) * np.cos(theta)], axis=1)
    omega = np.stack([rates[:, 1] * np.cos(theta), rates[:, 0], -rates[:, 1] * np.sin(theta)], axis=1)
    return (omega - np.sum(omega * q, axis=1, keepdims=True) * q).ravel()


def raw_velocities(config: ChainCartConfig, before: np.ndarray, now: np.ndarray) -> np.ndarray:
    """The expected velocity part (cart, then links) of reading `now` after `before`."""
    dt = config.dt
    cart = (parts(config, now)["x"] - parts(config, before)["x"]) / dt
    a0, a1 = link_angles(config, before), link_angles(config, now)
    rates = (a1 - a0) / dt
    rates[:, 0] = wrapped(a1[:, 0] - a0[:, 0]) / dt
    return np.concatenate([cart, spins(config, a1, rates)])


def velocities(config: ChainCartConfig, obs: np.ndarray) -> np.ndarray:
    p = parts(config, obs)
    return np.concatenate([p["xdot"], p["w"]])


SCENES = ["inverted-2", "spatial-inverted-2"]


@pytest.mark.parametrize("scene", SCENES)
def test_readings_sit_on_the_grid(scene: str) -> None:
    env = ChainCartEnv(scene=scene, start_noise=0.3, **ENCODERS)
    obs, _ = single_rollout(env, seed=3, steps=60)
    for o in obs:
        cart = parts(env.config, o)["x"] * CART_COUNTS
        np.testing.assert_allclose(cart, np.round(cart), atol=1e-8)
        counts = link_angles(env.config, o) * ANGLE_COUNTS / (2 * np.pi)
        np.testing.assert_allclose(counts, np.round(counts), atol=1e-8)
        q = parts(env.config, o)["q"].reshape(env.config.n_links, -1)
        np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)


def test_the_reading_rounds_down() -> None:
    env = ChainCartEnv(angle_encoder_counts=8, cart_encoder_counts=10.0, obs_dtype="float64")
    env.reset(seed=0)
    # x = 0.27 m reads 0.2; angles 0.5 and -0.1 rad read 0 and -pi/4 (grid pi/4).
    state = np.array([0.27, 1.0, np.sin(0.5), np.cos(0.5), np.sin(-0.1), np.cos(-0.1), 2.0, 3.0])
    env.unwrapped.set_state(state)
    obs = env.unwrapped._batch.observations()[0]
    expected = [0.2, 0.0, 0.0, 1.0, -np.sin(np.pi / 4), np.cos(np.pi / 4), 0.0, 0.0]
    np.testing.assert_allclose(obs, expected, rtol=0, atol=1e-15)


@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("tau", [0.0, 0.05])
def test_velocities_are_finite_differences_of_the_readings(scene: str, tau: float) -> None:
    env = ChainCartEnv(scene=scene, start_noise=0.3, max_episode_steps=25, velocity_filter=tau, **ENCODERS)
    obs, first = single_rollout(env, seed=8, steps=60)
    gain = 1.0 - np.exp(-env.config.dt / tau) if tau > 0 else 1.0
    assert sum(first) >= 3
    for t in range(1, len(obs)):
        got = velocities(env.config, obs[t])
        if first[t]:
            np.testing.assert_array_equal(got, 0.0)
            continue
        previous = velocities(env.config, obs[t - 1])
        expected = previous + gain * (raw_velocities(env.config, obs[t - 1], obs[t]) - previous)
        np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9)


def test_the_physics_is_the_same_with_or_without_encoders() -> None:
    sensed = ChainCartEnv(**ENCODERS, velocity_filter=0.02, start_noise=0.2)
    exact = ChainCartEnv(obs_dtype="float64", start_noise=0.2)
    for env in (sensed, exact):
        env.reset(seed=4)
    for step in range(30):
        a = actions(step, 1, 1)[0]
        o1, r1, *_ = sensed.step(a)
        o2, r2, *_ = exact.step(a)
        assert r1 == r2
        np.testing.assert_array_equal(sensed.unwrapped.state, exact.unwrapped.state)
        assert not np.array_equal(o1, o2)


@pytest.mark.parametrize("scene", SCENES)
def test_the_vector_env_is_n_single_envs_and_seeds_reproduce(scene: str) -> None:
    keywords = dict(scene=scene, velocity_filter=0.04, obs_noise=0.002, max_episode_steps=15, **ENCODERS)
    vec = ChainCartVectorEnv(3, **keywords, autoreset_mode="same_step")
    force_dim = vec.single_action_space.shape[0]
    obs = [vec.reset(seed=30)[0]]
    for step in range(40):
        obs.append(vec.step(actions(step, 3, force_dim))[0])
    again = ChainCartVectorEnv(3, **keywords, autoreset_mode="same_step")
    replay = [again.reset(seed=30)[0]] + [again.step(actions(s, 3, force_dim))[0] for s in range(40)]
    np.testing.assert_array_equal(np.stack(obs), np.stack(replay))
    for i in range(3):
        single = ChainCartEnv(**keywords)
        single_obs = [single.reset(seed=30 + i)[0]]
        for step in range(40):
            o, _, terminated, truncated, _ = single.step(actions(step, 3, force_dim)[i])
            if terminated or truncated:
                o = single.reset()[0]  # the vector env's same-step reset
            single_obs.append(o)
        np.testing.assert_array_equal(np.stack(single_obs), np.stack(obs)[:, i])


def test_copies_continue_the_readings_and_their_filter() -> None:
    env = ChainCartEnv(**ENCODERS, velocity_filter=0.05)
    env.reset(seed=2)
    for step in range(9):
        env.step(actions(step, 1, 1)[0])
    twin = copy.deepcopy(env)
    for step in range(9, 25):
        a = actions(step, 1, 1)[0]
        np.testing.assert_array_equal(env.step(a)[0], twin.step(a)[0])


def test_off_is_the_observation_of_before_bit_for_bit() -> None:
    """Seeded vector-env rollouts recorded before encoders existed (planar on the SIMD
    lanes; spatial with sensor noise, a drawn delay and randomised masses; swing-up with
    noise, force noise and same-step resets) are reproduced exactly."""
    recorded = np.load(BEFORE)
    cases = {
        "inverted2": (dict(scene="inverted-2", obs_dtype="float64", max_episode_steps=40), "next_step"),
        "spatial_noise_delay": (
            dict(
                scene="spatial-inverted-2",
                obs_dtype="float64",
                obs_noise=0.02,
                action_delay=(0, 2),
                randomize={"link_masses": 0.2},
                max_episode_steps=30,
            ),
            "next_step",
        ),
        "swingup_noise_same_step": (
            dict(scene="swingup-2", obs_noise=0.05, force_noise={"additive": 1.0}, max_episode_steps=25, obs_dtype="float64"),
            "same_step",
        ),
    }
    for name, (config, mode) in cases.items():
        env = ChainCartVectorEnv(3, config, autoreset_mode=mode)
        obs = [env.reset(seed=11)[0]]
        rng = np.random.default_rng(5)
        for _ in range(60):
            obs.append(env.step(rng.uniform(-1, 1, size=env.action_space.shape).astype(np.float32))[0])
        np.testing.assert_array_equal(np.stack(obs), recorded[name], err_msg=name)


def test_the_keys_default_to_off_and_round_trip() -> None:
    c = ChainCartConfig()
    assert (c.angle_encoder_counts, c.cart_encoder_counts, c.velocity_filter) == (None, None, 0.0)
    c = ChainCartConfig(angle_encoder_counts=1024.0, cart_encoder_counts=4000, velocity_filter=0.01)
    assert c.angle_encoder_counts == 1024 and isinstance(c.angle_encoder_counts, int)
    assert c.cart_encoder_counts == 4000.0 and isinstance(c.cart_encoder_counts, float)
    assert ChainCartConfig(**c.to_dict()) == c


@pytest.mark.parametrize(
    "keywords, needles",
    [
        (dict(angle_encoder_counts=0), ["angle_encoder_counts", "0", "an integer from 1"]),
        (dict(angle_encoder_counts=-4), ["angle_encoder_counts", "-4", "an integer from 1"]),
        (dict(angle_encoder_counts=2**33), ["angle_encoder_counts", "an integer from 1 to 4294967295"]),
        (dict(cart_encoder_counts=0.0), ["cart_encoder_counts", "counts per metre"]),
        (dict(cart_encoder_counts=float("nan")), ["cart_encoder_counts", "a finite number > 0"]),
        (dict(velocity_filter=0.1), ["velocity_filter", "0.1", "0 unless an encoder is on"]),
        (dict(cart_encoder_counts=100.0, velocity_filter=-1.0), ["velocity_filter", "-1", ">= 0"]),
        (dict(angle_encoder_reference="link"), ["angle_encoder_reference", "link", "\"vertical\", \"joint\""]),
        (dict(angle_encoder_reference="joint"), ["angle_encoder_reference", "angle_encoder_counts set"]),
        (dict(angle_encoder_reference="joint", angle_encoder_counts=1024, planar=False),
         ["angle_encoder_reference", "a planar chain"]),
    ],
)
def test_bad_values_are_named(keywords: dict, needles: list[str]) -> None:
    with pytest.raises(InvalidInputError) as e:
        ChainCartConfig(**keywords)
    for needle in needles:
        assert needle in str(e.value), str(e.value)


def test_a_non_integer_count_is_a_type_error() -> None:
    with pytest.raises(InvalidTypeError, match="angle_encoder_counts"):
        ChainCartConfig(angle_encoder_counts=10.5)


def test_the_command_line_takes_the_encoder_keywords() -> None:
    import argparse

    from chaincart_env.tools.compare.scene_options import add_scene_options, config_from_options

    parser = argparse.ArgumentParser()
    add_scene_options(parser)
    assert "--angle-encoder-counts" in parser.format_help() and "--velocity-filter" in parser.format_help()
    args = parser.parse_args(["--angle-encoder-counts", "1024", "--cart-encoder-counts", "2000", "--velocity-filter", "0.02"])
    c = config_from_options(args)
    assert (c.angle_encoder_counts, c.cart_encoder_counts, c.velocity_filter) == (1024, 2000.0, 0.02)


def test_joint_encoders_read_each_joint_on_the_grid_and_the_first_link_as_before() -> None:
    step = 2 * np.pi / ANGLE_COUNTS
    keywords = dict(scene="inverted-3-servo", start_noise=0.3, **ENCODERS)
    joint = ChainCartEnv(**keywords, angle_encoder_reference="joint")
    vertical = ChainCartEnv(**keywords)
    assert joint.unwrapped.config.angle_encoder_reference == "joint"
    rng = np.random.default_rng(0)
    obs_j, obs_v = joint.reset(seed=4)[0], vertical.reset(seed=4)[0]
    for _ in range(40):
        q = joint.unwrapped.config.state_layout["q"]
        angles = np.arctan2(obs_j[q[0]:q[1]:2], obs_j[q[0] + 1:q[1]:2])
        joints = np.angle(np.exp(1j * np.diff(angles, prepend=0.0)))
        np.testing.assert_allclose(joints / step, np.round(joints / step), atol=1e-7)
        np.testing.assert_array_equal(obs_j[: q[0] + 2], obs_v[: q[0] + 2])  # the cart and the first link
        action = rng.uniform(-1, 1, size=1).astype(np.float32)
        obs_j, obs_v = joint.step(action)[0], vertical.step(action)[0]
