"""The planner and the large-motion policies from Python: plans that replay on the
model, every transition of the double pendulum, MPC from perturbed starts, energy
shaping for one link, goals read from observations, and bad input named."""

from __future__ import annotations

import itertools
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest

import chaincart_env  # noqa: F401  (registers the envs)
from chaincart_env import (
    ChainCart,
    EnergyPolicy,
    InvalidInputError,
    MPCPolicy,
    PlanningError,
    TrajectoryPolicy,
)
from chaincart_env.config import ChainCartConfig
from chaincart_env.policies.settings import env_settings
from chaincart_env.tools.compare.evaluation import rollout

#: The default scene's physical system.
DOUBLE = ChainCart(2, 1.0, 0.1, 0.5, planar=True)
SIGNS_2 = [list(s) for s in itertools.product([1, -1], repeat=2)]


def run_episode(env: gym.Env, policy, seed: int) -> dict:  # type: ignore[no-untyped-def]
    obs, _ = env.reset(seed=seed)
    start = True
    while True:
        action, _ = policy.predict(obs, episode_start=np.array([start]))
        start = False
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            return info


def test_a_plan_replays_open_loop_on_the_model_and_reports_itself() -> None:
    plan = DOUBLE.plan("hanging", "inverted", max_force=20.0, duration=3.0)
    assert plan.converged, plan.report["reason"]
    steps = 150
    assert plan.times.shape == (steps + 1,) and plan.states.shape == (steps + 1, 8)
    assert plan.forces.shape == (steps, 1) and np.abs(plan.forces).max() <= 20.0
    np.testing.assert_allclose(plan.times[-1], 3.0)
    trajectory = DOUBLE.simulate(plan.states[0], plan.forces, 0.02, "rk4", 2)
    np.testing.assert_allclose(trajectory, plan.states, atol=1e-9)
    e_q, e_w = DOUBLE.errors(trajectory[-1], "inverted")
    assert e_q <= 0.1 and e_w <= 0.5
    report = plan.report
    assert report["reaches_target"] and report["within_track"] and report["reason"] == ""
    assert report["max_cart"] <= 2.4 and report["peak_force"] <= 20.0
    assert 0.0 < report["time_to_reach"] <= 3.0 and report["iterations"] >= 1


@pytest.mark.parametrize("start, target", [(s, t) for s in SIGNS_2 for t in SIGNS_2 if s != t])
def test_each_transition_of_the_double_pendulum_succeeds_with_the_trajectory_policy(start, target) -> None:  # type: ignore[no-untyped-def]
    # The goal-conditioned scene with its pair fixed: the target is read from the
    # observation, and a success holds the target for the scene's last second.
    env = gym.make("ChainCart-transitions-2-v0", start=start, target=target)
    policy = TrajectoryPolicy.from_env(env, duration=3.0)
    for seed in (0, 1):
        info = run_episode(env, policy, seed)
        assert info["is_success"], (start, target, seed, info)


def test_the_trajectory_policy_serves_every_drawn_transition() -> None:
    env = gym.make("ChainCart-transitions-2-v0")
    policy = TrajectoryPolicy.from_env(env)
    pairs = set()
    for seed in range(24):
        info = run_episode(env, policy, seed)
        assert info["is_success"], (seed, env.unwrapped.episode_target, info)
        pairs.add(env.unwrapped.episode_target)
    assert len(pairs) == 4  # every equilibrium was a target


def test_mpc_swings_the_double_pendulum_up_from_perturbed_starts() -> None:
    config = ChainCartConfig(scene="swingup-2", start_noise=0.1)
    policy = MPCPolicy.from_env(chaincart_env.ChainCartEnv(config), duration=3.0, budget=0.05)
    run = rollout(policy, "MPC", config, list(range(20)))
    assert run.success.mean() >= 0.95, run.success


def test_energy_shaping_swings_the_single_pendulum_up_from_every_seeded_start() -> None:
    env = gym.make("ChainCart-swingup-1-v0")
    policy = EnergyPolicy.from_env(env)
    for seed in range(10):
        info = run_episode(env, policy, seed)
        assert info["is_success"], (seed, info)


def test_the_target_is_read_from_a_goal_observation() -> None:
    env = chaincart_env.ChainCartEnv(ChainCartConfig(start="hanging", target="inverted", max_episode_steps=200))
    settings = replace(env_settings(env), goal_observation=True)
    policy = TrajectoryPolicy(settings, duration=3.0)
    base = env.unwrapped
    for target in ([-1, -1], [-1, 1]):
        obs, _ = env.reset(seed=3)
        start = True
        for _ in range(200):
            action, _ = policy.predict(np.concatenate([obs, target]), episode_start=np.array([start]))
            start = False
            obs, *_ = env.step(action)
        e_q, e_w = base.model.errors(base.model_state, target)
        assert e_q <= 0.1 and e_w <= 0.5, (target, e_q, e_w)
    assert len(policy._plans) == 2


def test_sb3_evaluate_policy_and_the_study_evaluation_reset_the_clock() -> None:
    from stable_baselines3.common.evaluation import evaluate_policy

    env = chaincart_env.ChainCartEnv(ChainCartConfig(start="hanging", target="inverted", max_episode_steps=200))
    policy = TrajectoryPolicy.from_env(env, duration=3.0)
    _, lengths = evaluate_policy(policy, env, n_eval_episodes=2, warn=False, return_episode_rewards=True)
    assert list(lengths) == [200, 200]
    config = ChainCartConfig(start="hanging", target="inverted", max_episode_steps=200)
    run = rollout(TrajectoryPolicy(env_settings(env), duration=3.0), "TVLQR", config, [0, 1, 2])
    assert run.success.all()


def test_bad_input_is_named() -> None:
    with pytest.raises(InvalidInputError, match="upside"):
        DOUBLE.plan("hanging", "upside", max_force=20.0)
    with pytest.raises(InvalidInputError, match="max_force = 0"):
        DOUBLE.plan("hanging", "inverted", max_force=0.0)
    bad = DOUBLE.equilibrium("hanging")
    bad[2] = np.nan
    with pytest.raises(InvalidInputError, match=r"start\[2\] = NaN"):
        DOUBLE.plan(bad, "inverted", max_force=20.0)
    with pytest.raises(InvalidInputError, match="duration = 0.01"):
        DOUBLE.plan("hanging", "inverted", max_force=20.0, duration=0.01)
    short = DOUBLE.plan("hanging", "inverted", max_force=20.0, duration=0.4, max_time=3.0)
    assert not short.converged and "duration = 0.4" in short.report["reason"]
    env = gym.make("ChainCart-v0", start="hanging", target="inverted")
    with pytest.raises(PlanningError, match="duration = 0.4"):
        TrajectoryPolicy.from_env(env, duration=0.4, max_time=3.0).predict(env.reset(seed=0)[0])
    plan = DOUBLE.plan("hanging", "inverted", max_force=20.0, duration=3.0)
    with pytest.raises(InvalidInputError, match="budget = 0"):
        plan.mpc(budget=0.0)
    with pytest.raises(InvalidInputError, match="iterations = 0"):
        plan.mpc(iterations=0)
    with pytest.raises(InvalidInputError, match=r"state\[1\] = inf"):
        plan.tracker().force(0, [0.0, np.inf] + [0.0] * 6)
    with pytest.raises(InvalidInputError, match="n_links"):
        chaincart_env._core.EnergyController(DOUBLE, 10.0)
    with pytest.raises(InvalidInputError, match="expected one link"):
        EnergyPolicy.from_env(env)
    with pytest.raises(InvalidInputError, match=r"plan_from = 'start': expected one of \['equilibrium', 'state'\]"):
        TrajectoryPolicy.from_env(env, plan_from="start")


def test_the_planners_cost_weights_are_checked_when_a_policy_is_built() -> None:
    defaults = chaincart_env._core.check_plan_weights()
    assert set(defaults) == {"x", "q", "v", "w", "force", "track", "terminal", "track_margin"}
    assert chaincart_env._core.check_plan_weights({"q": 2}) == {**defaults, "q": 2.0}
    env = gym.make("ChainCart-swingup-2-v0")
    for bad, message in (({"q": -1}, r"weights.q = -1: expected a finite number >= 0"),
                         ({"force": 0}, r"weights.force = 0"), ({"track_margin": 1.5}, r"weights.track_margin = 1.5"),
                         ({"qq": 1}, r"cost weight.*qq"), ({"q": "two"}, r"weights\["), (2.0, r"weights = 2.0: expected a dict")):
        for policy in (TrajectoryPolicy, MPCPolicy):  # refused at construction, before any plan
            with pytest.raises(InvalidInputError, match=message):
                policy.from_env(env, weights=bad)
    softer = TrajectoryPolicy.from_env(env, weights={"q": 2})
    assert softer.plan_options["weights"] == {**defaults, "q": 2.0}
    start = ChainCartConfig(scene="swingup-2").make_model().equilibrium("hanging")
    plans = [policy.plan((1, 1), (-1, -1)) for policy in (softer, TrajectoryPolicy.from_env(env))]  # the swing-up
    assert all(plan.converged for plan in plans) and np.allclose(plans[0].states[0], start)
    assert not np.allclose(plans[0].forces, plans[1].forces)  # the weights reach the planner


def test_a_scenes_plan_settings_are_the_policies_defaults_and_keywords_override_them() -> None:
    triple = TrajectoryPolicy.from_env(gym.make("ChainCart-transitions-3-v0"))
    assert (triple.duration, triple.plan_from) == (7.0, "state")
    double = MPCPolicy.from_env(gym.make("ChainCart-swingup-2-v0"))
    assert (double.duration, double.plan_from) == (None, "equilibrium")  # the planner's 1 + n s
    default = TrajectoryPolicy.from_env(gym.make("ChainCart-v0"))
    assert (default.duration, default.plan_from) == (None, "equilibrium")
    chosen = TrajectoryPolicy.from_env(gym.make("ChainCart-swingup-3-v0"), duration=8.0, plan_from="equilibrium")
    assert (chosen.duration, chosen.plan_from) == (8.0, "equilibrium")


@pytest.mark.parametrize("start, target", [([1, -1, -1], [-1, 1, 1]), ([1, -1, 1], [1, -1, -1])])
def test_three_link_transitions_succeed_with_plans_from_each_episodes_start(start, target) -> None:  # type: ignore[no-untyped-def]
    # Two of the hardest transitions: upright links above a hanging first one at the start,
    # which the chain leaves at once. The scene's defaults (7 s plans from each episode's
    # observed start) serve them.
    env = gym.make("ChainCart-transitions-3-v0", start=start, target=target)
    policy = TrajectoryPolicy.from_env(env)
    for seed in (0, 1):
        info = run_episode(env, policy, seed)
        assert info["is_success"], (start, target, seed, info)
    assert len(policy._plans) == 0  # every episode followed its own plan, none from the equilibrium


def test_the_planner_swings_up_five_links() -> None:
    # The longest chain the planner aims at: five links of the default scene's physics,
    # within 60 N and a 5 m track over 8 s (see docs/control.md for the settings tried).
    five = ChainCart(5, 1.0, 0.1, 0.5, planar=True)
    plan = five.plan("hanging", "inverted", max_force=60.0, track_limit=5.0, duration=8.0, guesses=20,
                     max_iterations=5000, max_time=300.0)
    assert plan.converged, plan.report["reason"]
    assert np.abs(plan.forces).max() <= 60.0 and np.abs(plan.states[:, 0]).max() <= 5.0
    replay = five.simulate(plan.states[0], plan.forces, 0.02, "rk4", 2)
    e_q, e_w = five.errors(replay[-1], "inverted")
    assert e_q <= 0.1 and e_w <= 0.5
