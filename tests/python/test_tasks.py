"""The large-motion scenes and goal-conditioned tasks from Python: the observation's
target tail, the draws over all transitions (seeded, fixed by keywords, limited by a
list), the bounded reward, success held for the last seconds, the goal-conditioned
LQR, and clear errors."""

from __future__ import annotations

import csv
import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import chaincart_env  # noqa: F401  (registers the ids)
from chaincart_env import ChainCartConfig, ChainCartEnv, ChainCartVectorEnv, LQRPolicy
from chaincart_env.errors import ChainCartError

LARGE_MOTION_SCENES = ["swingup-2", "swingup-3", "spatial-swingup-2", "transitions-2", "transitions-3"]


@pytest.mark.parametrize("scene", LARGE_MOTION_SCENES)
def test_large_motion_scenes_pass_gymnasiums_checker(scene: str) -> None:
    env = gym.make(f"ChainCart-{scene}-v0")
    check_env(env.unwrapped, skip_render_check=True)
    config = env.unwrapped.config
    assert config.reward == "tolerance" and config.success_hold == 1.0
    goal = scene.startswith("transitions")
    assert env.observation_space.shape == (config.state_dim + (config.n_links if goal else 0),)
    env.close()


def test_transitions_observe_their_drawn_target_and_draw_every_pair() -> None:
    env = gym.make("ChainCart-transitions-2-v0")
    base = env.unwrapped
    n, d = 2, base.config.state_dim
    pairs = set()
    for seed in range(80):
        obs, _ = env.reset(seed=seed)
        target = tuple(int(v) for v in obs[d:])
        assert target == base.episode_target
        # The start: each link near the pair's start equilibrium, which is not the target.
        q_vertical = base.model_state[2 + 1 : 2 + 2 * n : 2]
        start = tuple(int(np.sign(v)) for v in q_vertical)
        assert start != target
        pairs.add((start, target))
    assert len(pairs) == 12
    # Seeded: the same seed, the same pair and start.
    first, _ = env.reset(seed=7)
    again, _ = env.reset(seed=7)
    np.testing.assert_array_equal(first, again)


def test_keywords_fix_the_pair_or_limit_the_draw() -> None:
    env = gym.make("ChainCart-transitions-2-v0", start=[1, 1], target=[-1, 1])
    d = env.unwrapped.config.state_dim
    for seed in range(5):
        obs, _ = env.reset(seed=seed)
        assert tuple(obs[d:]) == (-1, 1)
        assert np.all(env.unwrapped.model_state[[3, 5]] > 0)  # both links hang
    listed = [((1, 1), (-1, -1)), ("inverted", "hanging")]
    env = gym.make("ChainCart-transitions-2-v0", transitions=listed)
    targets = {tuple(env.reset(seed=s)[0][d:]) for s in range(30)}
    assert targets == {(-1, -1), (1, 1)}
    assert env.unwrapped.config.pairs == [((1, 1), (-1, -1)), ((-1, -1), (1, 1))]


def test_a_vector_env_equals_single_envs_on_drawn_transitions() -> None:
    from gymnasium.vector import AutoresetMode

    n_envs = 5
    vec = ChainCartVectorEnv(n_envs, scene="transitions-2", max_episode_steps=12, autoreset_mode=AutoresetMode.SAME_STEP)
    singles = [ChainCartEnv(scene="transitions-2", max_episode_steps=12) for _ in range(n_envs)]
    obs, _ = vec.reset(seed=3)
    for i, env in enumerate(singles):
        np.testing.assert_array_equal(obs[i], env.reset(seed=3 + i)[0])
    rng = np.random.default_rng(0)
    ends = 0
    for _ in range(40):
        actions = rng.uniform(-1, 1, size=(n_envs, 1)).astype(np.float32)
        obs, rewards, terminated, truncated, info = vec.step(actions)
        for i, env in enumerate(singles):
            o, r, te, tr, _ = env.step(actions[i])
            assert rewards[i] == r and terminated[i] == te and truncated[i] == tr
            if te or tr:
                ends += 1
                np.testing.assert_array_equal(info["final_obs"][i], o)
                o, _ = env.reset()  # the same stream draws the next pair and start
            np.testing.assert_array_equal(obs[i], o)
            np.testing.assert_array_equal(vec.episode_targets[i], env.episode_target)
    assert ends >= n_envs
    vec.close()


def test_the_tolerance_reward_is_bounded_and_one_at_rest_on_the_target() -> None:
    env = ChainCartEnv(scene="swingup-2", start="target", start_noise=0.0)
    env.reset(seed=0)
    _, reward, *_ = env.step(np.zeros(1, np.float32))
    assert reward == pytest.approx(1.0, abs=1e-9)
    env = ChainCartEnv(scene="swingup-2")
    env.reset(seed=1)
    rng = np.random.default_rng(1)
    rewards = []
    for _ in range(300):
        _, r, te, tr, _ = env.step(rng.uniform(-1, 1, 1).astype(np.float32))
        rewards.append(r)
        if te or tr:
            env.reset()
    assert 0.0 <= min(rewards) and max(rewards) <= 1.0
    assert min(rewards) < 0.5  # far from the target, far from 1


def test_success_waits_for_the_hold() -> None:
    # Resting on the hanging equilibrium for 0.6 s: a success with a 0.5 s hold, not 1 s.
    for hold, success in [(0.5, True), (1.0, False)]:
        env = ChainCartEnv(target="hanging", start="target", start_noise=0.0, max_episode_steps=30, success_hold=hold)
        env.reset(seed=0)
        for _ in range(30):
            *_, truncated, info = env.step(np.zeros(1, np.float32))
        assert truncated and info["is_success"] is success


def test_the_lqr_reads_the_target_from_the_observation() -> None:
    # Every episode starts near its drawn target: the goal-conditioned LQR holds each of
    # the four equilibria, a single-target LQR only its own.
    config = dict(scene="transitions-2", start="target", max_episode_steps=100)
    env = ChainCartEnv(**config)
    policy = LQRPolicy.from_env(env)
    held = set()
    for seed in range(12):
        obs, _ = env.reset(seed=seed)
        for _ in range(100):
            obs, _, terminated, truncated, info = env.step(policy.predict(obs)[0])
            if terminated or truncated:
                break
        assert info["is_success"], (seed, env.episode_target)
        held.add(env.episode_target)
    assert len(held) == 4
    with pytest.raises(ValueError, match="expected"):
        LQRPolicy.from_env(ChainCartEnv(scene="swingup-2")).predict(obs)  # obs has the tail


@pytest.mark.parametrize(
    "keywords, message",
    [
        (dict(target="any", n_links=9), "at most 8"),
        (dict(target="any", start="paper-fig1", n_links=5), "expected an equilibrium"),
        (dict(transitions=[((1, 0.5), (1, 1))]), "0.5"),
        (dict(transitions="hanging"), "transitions"),
        (dict(transitions=[(1, 1)]), "transitions start = 1: expected a name or a sequence"),
        (dict(transitions=[((1, 1),)]), "(start, target) pair"),
        (dict(success_hold=-1.0), "success_hold"),
        (dict(fall_limit=-0.5), "fall_limit = -0.5: expected a finite number >= 0"),
        (dict(reward="quadratic"), "tolerance"),
    ],
)
def test_bad_task_values_are_clear_errors(keywords: dict, message: str) -> None:
    with pytest.raises(ChainCartError) as error:
        ChainCartConfig(**keywords)
    assert message in str(error.value)


def test_goal_conditioned_configs_round_trip_and_pickle() -> None:
    import pickle

    config = ChainCartConfig(scene="transitions-2", transitions=[([1, 1], "inverted")])
    again = ChainCartConfig(**config.to_dict())
    assert again == config and again.pairs == [((1, 1), (-1, -1))]
    assert pickle.loads(pickle.dumps(config)) == config
    assert config.goal_conditioned and not ChainCartConfig(scene="swingup-2").goal_conditioned


def test_the_transitions_command_plans_tracks_and_writes_its_table(tmp_path, capsys) -> None:
    from chaincart_env.__main__ import main

    code = main(["transitions", "--links", "1", "--max-force", "10", "--track-limit", "3", "--duration", "3",
                 "--hold", "0.5", "--seeds", "2", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert code in (0, 1)
    rows = (tmp_path / "transitions_1.csv").read_text().splitlines()
    assert rows[0].startswith("start,target,planned") and len(rows) == 3  # two transitions of one link
    assert "| (+) | (-) | yes | 2/2 |" in out  # the swing-up is planned and tracked from both starts
    # Planning from each episode's start, with time to spare before the hold: one more
    # second per episode, the same table.
    code = main(["transitions", "--links", "1", "--max-force", "10", "--track-limit", "3", "--duration", "3",
                 "--hold", "0.5", "--spare", "1", "--seeds", "2", "--plan-from", "state"])
    assert code == 0 and "| (+) | (-) | yes | 2/2 |" in capsys.readouterr().out


def test_animate_draws_a_swing_up_by_the_planners_controller(tmp_path) -> None:
    from chaincart_env.errors import InvalidInputError
    from chaincart_env.tools.animate import animate

    still = animate(ChainCartConfig(scene="swingup-2"), tmp_path / "swingup.png", policy="trajectory",
                    times=[0.0, 2.5], width=120, height=160)
    assert still.path.is_file() and still.endings == ("step limit",) and still.policies == ("trajectory",)
    soft = animate(ChainCartConfig(scene="swingup-2"), tmp_path / "soft.png", policy="trajectory-soft",
                   times=[0.0, 2.5], width=120, height=160)
    assert soft.endings == ("step limit",) and soft.policies == ("trajectory-soft",)
    with pytest.raises(InvalidInputError, match="energy cannot serve scene 'swingup-2'"):
        animate(ChainCartConfig(scene="swingup-2"), tmp_path / "x.png", policy="energy", times=[0.0])


def test_frames_show_the_ghost_of_each_episodes_own_target() -> None:
    from chaincart_env.rendering import ChainRenderer

    env = ChainCartEnv(scene="transitions-2", render_mode="rgb_array", render_width=96, render_height=96)
    renderer = ChainRenderer(env.config, 96, 96)
    frames = {}
    for seed in range(12):
        env.reset(seed=seed)
        target = env.episode_target
        frame = env.render()
        np.testing.assert_array_equal(frame, renderer.frame(env.model_state, target=target))
        frames[target] = frame
    assert len(frames) > 1
    (a, fa), (b, fb) = list(frames.items())[:2]
    assert not np.array_equal(renderer.frame(env.model_state, target=a), renderer.frame(env.model_state, target=b))


def test_a_plan_that_misses_raises_or_is_tracked_to_a_failed_episode() -> None:
    import warnings as _warnings

    from chaincart_env.errors import PlanningError
    from chaincart_env.policies import TrajectoryPolicy
    from chaincart_env.tools.controllers import build_model_based

    # Three links, a 1 s plan from hanging to upright: no plan reaches the target.
    env = ChainCartEnv(scene="swingup-3", max_episode_steps=60)
    obs, _ = env.reset(seed=0)
    with pytest.raises(PlanningError, match="no plan from"):
        TrajectoryPolicy.from_env(env, duration=1.0, max_time=2.0).predict(obs)
    with pytest.raises(ChainCartError, match="on_failure = 'ignore'"):
        TrajectoryPolicy.from_env(env, on_failure="ignore")
    policy = TrajectoryPolicy.from_env(env, duration=1.0, max_time=2.0, on_failure="track")
    with _warnings.catch_warnings(record=True) as caught:
        _warnings.simplefilter("always")
        for _ in range(60):
            obs, _, terminated, truncated, info = env.step(policy.predict(obs)[0])
            if terminated or truncated:
                break
    assert not info["is_success"] and policy.failed_pairs == {((1, 1, 1), (-1, -1, -1))}
    assert any("tracking it all the same" in str(w.message) for w in caught)
    # The study's registry tracks missed plans, so a run counts them as failures.
    assert build_model_based("trajectory", env.config).on_failure == "track"


def test_the_soft_trajectory_controller_is_the_planners_with_its_own_weights_in_every_build() -> None:
    from chaincart_env import _core
    from chaincart_env.tools.controllers import SOFT_PLAN_WEIGHTS, build_model_based, parse_controllers
    from chaincart_env.tools.leaderboard.contestants import DesignSource

    config = ChainCartConfig(scene="swingup-2", max_episode_steps=60)
    soft_weights = _core.check_plan_weights(dict(SOFT_PLAN_WEIGHTS))
    assert parse_controllers("Trajectory-Soft,trajectory") == ["trajectory-soft", "trajectory"]
    study = build_model_based("trajectory-soft", config)
    fixed, timed = (DesignSource.of("trajectory-soft", config, wall_clock=w).build() for w in (False, True))
    for policy in (study, fixed, timed):  # the study's build and the leaderboard's, with and without time limits
        assert policy.plan_options["weights"] == soft_weights and policy.on_failure == "track"
    assert fixed.plan_options["max_time"] == math.inf and "max_time" not in timed.plan_options
    assert "weights" not in build_model_based("trajectory", config).plan_options
    env = ChainCartEnv(config)
    obs, _ = env.reset(seed=0)
    soft, plain = study.predict(obs)[0], build_model_based("trajectory", config).predict(obs)[0]
    assert not np.array_equal(soft, plain)  # another plan, another command


def test_a_rendering_goal_conditioned_env_pickles_with_its_episode_target() -> None:
    import pickle

    env = ChainCartEnv(scene="transitions-2", render_mode="rgb_array", render_width=64, render_height=64)
    env.reset(seed=3)
    copy = pickle.loads(pickle.dumps(env))
    assert copy.episode_target == env.episode_target
    np.testing.assert_array_equal(copy.render(), env.render())


def test_the_main_job_trains_and_compares_on_a_goal_conditioned_scene(tmp_path) -> None:
    """Periodic evaluation, the study's episodes and the filmstrip read the state part of
    observations that carry the target's signs, and each episode is measured against its
    own drawn target from its start on."""
    from chaincart_env.__main__ import main
    from chaincart_env.policies import TrajectoryPolicy
    from chaincart_env.tools.compare.evaluation import rollout

    out = tmp_path / "run"
    code = main(["compare", "--scene", "transitions-2", "--policies", "ppo,trajectory", "--timesteps", "2048",
                 "--num-envs", "4", "--eval-every", "1024", "--eval-starts", "4", "--sweep", "start_noise=0.05",
                 "--eval-episodes", "4", "--no-imitation", "--no-progress", "--out", str(out)])
    assert code == 0 and (out / "report.md").is_file() and (out / "filmstrip.png").is_file()
    assert len((out / "seed-0" / "evaluations.csv").read_text().splitlines()) >= 3
    with (out / "transitions.csv").open(newline="") as file:
        per_pair = list(csv.DictReader(file))
    with (out / "episodes.csv").open(newline="") as file:
        episodes = list(csv.DictReader(file))
    for policy in ("PPO (seed 0)", "Trajectory"):
        rows = [row for row in per_pair if row["policy"] == policy]
        assert sum(int(row["episodes"]) for row in rows) == 4 and all(row["start"] != row["target"] for row in rows)
        mine = [row for row in episodes if row["policy"] == policy]
        assert sum(int(row["successes"]) for row in rows) == sum(int(row["is_success"]) for row in mine)
    assert "## Per transition" in (out / "report.md").read_text()

    config = ChainCartConfig(scene="transitions-2")
    run = rollout(TrajectoryPolicy.from_env(ChainCartEnv(config)), "trajectory", config, [0, 1, 2, 3])
    model, batch = config.make_model(), config.make_batch(4, "same_step")
    batch.reset([0, 1, 2, 3], None)
    for i, (state, target) in enumerate(zip(batch.states(), batch.targets())):
        assert run.e_q[i, 0] == model.errors(state, tuple(int(s) for s in target))[0]
    assert len({tuple(t) for t in batch.targets()}) > 1 and run.success.all()
