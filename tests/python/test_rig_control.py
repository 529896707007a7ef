"""The model-based controllers on a real rig: the LQR designs on the linearisation with
the rig (damping, friction, acceleration or voltage actuation) and commands in the
actuation's unit; the planner, its tracker and MPC plan on the model with the rig
and command in the actuation's unit; the energy controller refuses an actuation other
than a force, naming it; the scenes of real rigs build, step, match their documented
values and are held by the LQR."""

from __future__ import annotations

import ast
import dataclasses
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from chaincart_env import ChainCartConfig, ChainCartEnv
from chaincart_env.errors import InvalidInputError
from chaincart_env.policies import EnergyPolicy, LQRPolicy, MPCPolicy, OracleLQRPolicy, TrajectoryPolicy
from chaincart_env.policies.lqr import lqr_coordinates

RIGS = {
    "damped": dict(joint_damping=[0.03, 0.01], cart_viscous_friction=2.0),
    "acceleration": dict(actuation="acceleration", max_acceleration=15.0, joint_damping=0.01),
    "voltage": dict(actuation="voltage", max_voltage=12.0, cart_viscous_friction=1.0),
}
RIG_SCENES = ("inverted-2-motor", "inverted-3-servo")
DOCS = Path(__file__).resolve().parents[2] / "docs"


def episode(env: ChainCartEnv, policy: LQRPolicy, seed: int) -> tuple[bool, bool]:
    """(terminated, is_success) of one episode under ``policy``."""
    obs, _ = env.reset(seed=seed)
    while True:
        obs, _, terminated, truncated, info = env.step(policy.predict(obs)[0])
        if terminated or truncated:
            return terminated, bool(info.get("is_success", False))


def test_without_a_rig_the_design_is_the_models() -> None:
    env = ChainCartEnv()
    policy = LQRPolicy.from_env(env)
    np.testing.assert_array_equal(policy.gain, env.model.lqr_gain(list(env.config.target_signs)))
    np.testing.assert_array_equal(env.config.lqr_gain(env.config.target_signs), policy.gain)
    assert policy.max_force == env.config.max_force


@pytest.mark.parametrize("rig", list(RIGS))
def test_the_lqr_designs_with_the_rig_and_commands_in_its_unit(rig: str) -> None:
    config = ChainCartConfig(**RIGS[rig])
    env = ChainCartEnv(config)
    policy = LQRPolicy.from_env(env)
    ideal = env.model.lqr_gain(list(config.target_signs))
    assert policy.max_force == config.command_scale
    assert np.max(np.abs(policy.gain - ideal)) > 1e-3 * np.max(np.abs(ideal))
    np.testing.assert_array_equal(policy.gain, config.lqr_gain(config.target_signs))
    obs, _ = env.reset(seed=3)
    z = lqr_coordinates(_spatial(obs, config.n_links), config.target_signs)
    expected = np.clip(-(z @ policy.gain.T)[:, :1] / config.command_scale, -1, 1)
    np.testing.assert_allclose(policy.predict(obs)[0], expected[0], rtol=1e-6, atol=1e-7)


def _spatial(obs: np.ndarray, n: int) -> np.ndarray:
    from chaincart_env.policies.lqr import _planar_to_spatial

    return _planar_to_spatial(np.atleast_2d(obs), n)


def test_the_linearisation_with_the_rig_has_the_closed_forms() -> None:
    # A planar pendulum of one link on a servo axis: theta'' = (g th - a) / l (upright,
    # angle th from upright) less the damping c w / (m l^2); in voltage mode the cart
    # feels k (V - k v) / R besides the chain.
    m, length, c = 0.2, 0.4, 0.01
    config = ChainCartConfig(
        n_links=1, link_masses=m, link_lengths=length, joint_damping=c, actuation="acceleration"
    )
    a, b = config._resolved.linearize([-1])
    # z = [x(2), xi(2), xdot(2), w(2)]: the cart row is a double integrator driven by a.
    np.testing.assert_allclose(b[4:6], np.eye(2), atol=1e-12)
    np.testing.assert_allclose(a[4:6], 0.0, atol=1e-12)
    np.testing.assert_allclose(np.abs(a[6, 2]), 9.81 / length, rtol=1e-12)
    np.testing.assert_allclose(a[6, 6], -c / (m * length * length), rtol=1e-12)
    np.testing.assert_allclose(np.abs(b[6, 0]) + np.abs(b[6, 1]), 1.0 / length, rtol=1e-12)
    motor = (0.02, 2.0, 5.0, 0.02, 5.0)
    k = motor[2] * motor[0] / motor[3]
    volt = ChainCartConfig(n_links=1, actuation="voltage", motor=motor, cart_viscous_friction=0.5)
    force = ChainCartConfig(n_links=1)
    (av, bv), (af, bf) = volt._resolved.linearize([-1]), force._resolved.linearize([-1])
    np.testing.assert_allclose(bv, bf * k / motor[1], rtol=1e-12)
    # The cart's damping (b + k^2 / R) enters through the same column as the input.
    np.testing.assert_allclose(av[:, 4:5] - af[:, 4:5], -bf[:, :1] * (0.5 + k * k / motor[1]), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("rig", list(RIGS))
def test_the_lqr_designed_with_the_rig_holds_the_rig(rig: str) -> None:
    env = ChainCartEnv(ChainCartConfig(**RIGS[rig]))
    policy = LQRPolicy.from_env(env)
    for seed in range(3):
        terminated, success = episode(env, policy, seed)
        assert not terminated and success, (rig, seed)


def test_controllability_counts_joint_damping_and_nothing_else_of_the_rig() -> None:
    target = (-1, -1)
    model = ChainCartConfig().make_model().controllability(list(target))
    assert ChainCartConfig().controllability(target) == model
    # Cart friction, a motor or a servo axis leave Prop. 3's verdict and margin as they are.
    for rig in RIGS.values():
        if "joint_damping" not in rig:
            assert ChainCartConfig(**rig).controllability(target) == model
    damped, margin = ChainCartConfig(joint_damping=[0.02, 0.01]).controllability(target)
    assert damped and margin != model[1] and abs(margin - model[1]) < 0.2 * model[1]


def test_the_lqr_holds_a_cart_with_coulomb_friction() -> None:
    # Designed on the Coulomb law's slope at rest (1 N over 0.01 m/s: 100 N s/m of cart
    # damping), the gain lost the chain from every start; the design leaves it out.
    config = ChainCartConfig(cart_coulomb_friction=1.0)
    env = ChainCartEnv(config)
    policy = LQRPolicy.from_env(env)
    np.testing.assert_allclose(policy.gain, ChainCartConfig().lqr_gain(config.target_signs), rtol=1e-12, atol=1e-12)
    for seed in range(5):
        terminated, success = episode(env, policy, seed)
        assert not terminated and success, seed


def test_the_oracle_designs_with_the_rig_on_the_true_parameters() -> None:
    config = ChainCartConfig(**RIGS["voltage"], mismatch={"cart_mass": 0.3})
    env = ChainCartEnv(config)
    env.reset(seed=1)
    oracle = OracleLQRPolicy(env)
    true = env.unwrapped.true_params
    expected = config.replace(cart_mass=float(true["cart_mass"]), mismatch=None).lqr_gain(config.target_signs)
    np.testing.assert_allclose(oracle.gains()[0], expected, rtol=1e-12)
    assert oracle.max_force == config.command_scale


@pytest.mark.parametrize("actuation", ["acceleration", "voltage"])
def test_the_energy_controller_refuses_another_actuation_naming_it(actuation: str) -> None:
    env = ChainCartEnv(ChainCartConfig(scene="swingup-1", actuation=actuation))
    with pytest.raises(InvalidInputError, match=rf"actuation = '{actuation}': EnergyPolicy computes cart forces"):
        EnergyPolicy.from_env(env)


@pytest.mark.parametrize("rig", sorted(RIGS))
def test_the_rig_model_steps_as_the_rig_env(rig: str) -> None:
    config = ChainCartConfig(scene="swingup-2", **RIGS[rig])
    env = ChainCartEnv(config)
    model = config.rig_model()
    env.reset(seed=3)
    for action in (0.75, -0.375, 1.0):  # exact in float32, the action's dtype
        before = env.unwrapped.model_state.copy()
        env.step(np.array([action], dtype=np.float32))
        expected = model.step(before, [action * config.command_scale], config.dt, "rk4", config.substeps)
        np.testing.assert_allclose(env.unwrapped.model_state, expected, rtol=0, atol=1e-12)
    ideal = config.make_model().step(before, [config.command_scale], config.dt, "rk4", config.substeps)
    assert np.max(np.abs(ideal - expected)) > 1e-6  # the rig moves the chain otherwise


def swing_ups(env: ChainCartEnv, policy: Any, seeds: range) -> list[bool]:
    """``is_success`` of one episode from each seeded start."""
    successes = []
    for seed in seeds:
        obs, _ = env.reset(seed=seed)
        policy.reset()
        while True:
            obs, _, terminated, truncated, info = env.step(policy.predict(obs)[0])
            if terminated or truncated:
                successes.append(bool(info.get("is_success", False)))
                break
    return successes


@pytest.mark.parametrize("rig", sorted(RIGS))
@pytest.mark.parametrize("policy", [TrajectoryPolicy, MPCPolicy])
def test_the_planners_swing_up_on_every_rig(policy: type, rig: str) -> None:
    env = ChainCartEnv(ChainCartConfig(scene="swingup-2", **RIGS[rig]))
    controller = policy.from_env(env)
    assert controller.settings.max_force == env.unwrapped.config.command_scale
    assert swing_ups(env, controller, range(3)) == [True, True, True]


def test_the_plan_on_the_rig_swings_up_where_the_ideal_models_plan_fails() -> None:
    env = ChainCartEnv(ChainCartConfig(scene="swingup-2", **RIGS["damped"]))
    on_rig = TrajectoryPolicy.from_env(env)
    on_ideal = TrajectoryPolicy(dataclasses.replace(on_rig.settings, model=env.unwrapped.config.make_model()))
    assert swing_ups(env, on_rig, range(3)) == [True, True, True]
    assert swing_ups(env, on_ideal, range(3)) == [False, False, False]


def test_force_controllers_serve_a_damped_force_rig() -> None:
    env = ChainCartEnv(ChainCartConfig(scene="swingup-1", joint_damping=0.001))
    assert EnergyPolicy.from_env(env).predict(env.reset(seed=0)[0])[0].shape == (1,)


def documented_scene_values(scene: str) -> dict[str, str]:
    """The ``key = value`` pairs the sim-to-real page lists for ``scene``."""
    text = (DOCS / "sim-to-real.md").read_text()
    block = text.split(f"### `{scene}`", 1)[1].split("\n#", 1)[0]
    return dict(re.findall(r"^\| `(\w+)` \| `([^`]+)` \|", block, flags=re.M))


@pytest.mark.parametrize("scene", RIG_SCENES)
def test_the_rig_scenes_have_the_documented_values(scene: str) -> None:
    config = ChainCartConfig(scene=scene)
    documented = documented_scene_values(scene)
    assert len(documented) >= 5
    for key, text in documented.items():
        value = getattr(config, key)
        expected = ast.literal_eval(text)
        if isinstance(value, tuple) and not isinstance(expected, tuple):
            expected = (expected,) * len(value) if key != "motor" else expected
        assert value == expected or np.allclose(value, expected, rtol=0, atol=0), (key, value, text)
    assert config.has_rig_effects


@pytest.mark.parametrize("scene", RIG_SCENES)
def test_the_rig_scenes_build_step_and_are_held_by_the_lqr(scene: str) -> None:
    env = ChainCartEnv(scene=scene)
    obs, _ = env.reset(seed=0)
    obs, *_ = env.step(env.action_space.sample() * 0)
    assert np.all(np.isfinite(obs))
    policy = LQRPolicy.from_env(env)
    for seed in range(3):
        terminated, success = episode(env, policy, seed)
        assert not terminated and success, (scene, seed)
