"""The plan tube: an episode whose chain leaves the tube around the planner's path ends
on that step, as a termination with the episode keys and its terminal observation, and
the env starts its next episode as the native envs would; episodes within the tube run
exactly as without it. Its radius is checked by name, it pickles, the compare option
records it and refuses it where there is no single plan, and a tiny training with it is
seeded and logs the episodes it ended."""

from __future__ import annotations

import csv
import pickle

import numpy as np
import pytest

from chaincart_env import ChainCartConfig, ChainCartVecEnv
from chaincart_env.__main__ import main
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.curriculum import PlanStarts, plan_states
from chaincart_env.tools.compare.job import _training_settings
from chaincart_env.tools.compare.plan_path import RATE_WEIGHT, PlanPath
from chaincart_env.tools.compare.plan_tube import PlanTube
from chaincart_env.tools.compare.shaping import LEFT_PLAN, Shaping, check_plan_tube

SWINGUP = ChainCartConfig(scene="swingup-2", max_episode_steps=60)
RADIUS = 0.8


@pytest.fixture(scope="module")
def plan() -> np.ndarray:
    return plan_states(SWINGUP)


def _spun(model) -> np.ndarray:
    """The upright chain spinning at 30 rad/s per link: 3 from the plan's nearest state
    in the tube's distance at least, so outside a tube of RADIUS."""
    state = model.equilibrium([-1, -1]).copy()
    start, stop = model.state_layout["w"]
    state[start:stop] = 30.0
    return state


def test_the_distance_is_the_link_directions_and_a_tenth_of_the_spins(plan) -> None:
    model = ChainCartVecEnv(1, SWINGUP).model
    path = PlanPath(model, plan)
    assert path.knots == len(plan)
    assert np.allclose(path.squared_distances(plan).diagonal(), 0.0)
    moved = plan[:3].copy()
    moved[:, 0] += 1.0  # the cart's place is left out
    (q_start, _), (w_start, _) = model.state_layout["q"], model.state_layout["w"]
    moved[:, w_start] += 2.0
    moved[:, q_start] += 0.5
    expected = (0.5**2 + (RATE_WEIGHT * 2.0) ** 2)
    assert np.allclose(path.squared_distances(moved)[np.arange(3), np.arange(3)], expected)
    with pytest.raises(InvalidInputError, match=r"plan of shape \(151, 3\)"):
        PlanPath(model, plan[:, :3])


def test_an_episode_that_leaves_the_tube_ends_there_and_the_next_begins(plan) -> None:
    plain = ChainCartVecEnv(3, SWINGUP, seed=4)
    tube = PlanTube(ChainCartVecEnv(3, SWINGUP, seed=4), plan, RADIUS)
    actions = np.zeros((3, 1), dtype=np.float32)
    np.testing.assert_array_equal(plain.reset(), tube.reset())
    for envs in (plain, tube):
        envs.env_method("set_state", _spun(envs.unwrapped.model), indices=1)
    stepped_plain, rewards_plain, dones_plain, _ = plain.step(actions)
    stepped, rewards, dones, infos = tube.step(actions)
    assert not dones_plain.any()
    assert dones.tolist() == [False, True, False]
    info = infos[1]
    assert info[LEFT_PLAN] and not info["TimeLimit.truncated"]
    assert not (info["is_success"] or info["fell"] or info["out_of_track"] or info["numerical_failure"])
    assert info["e_w"] > 10.0
    np.testing.assert_array_equal(info["terminal_observation"], stepped_plain[1])
    np.testing.assert_array_equal(rewards, rewards_plain)  # the step's reward stays the scene's
    np.testing.assert_array_equal(stepped[[0, 2]], stepped_plain[[0, 2]])  # the other envs untouched
    native = tube.unwrapped
    assert native._batch.step_counts()[1] == 0  # a new episode, not the old one moved
    assert PlanPath(native.model, plan).squared_distances(native._batch.states()[1:2]).min() < RADIUS**2
    assert not np.array_equal(stepped[1], stepped_plain[1])
    assert tube.episodes_ended == 1


def test_episodes_within_the_tube_run_as_without_it(plan) -> None:
    plain = ChainCartVecEnv(4, SWINGUP, seed=9)
    wide = PlanTube(ChainCartVecEnv(4, SWINGUP, seed=9), plan, 100.0)
    rng = np.random.default_rng(0)
    np.testing.assert_array_equal(plain.reset(), wide.reset())
    for _ in range(130):  # past two 60-step episodes
        actions = rng.uniform(-1, 1, (4, 1)).astype(np.float32)
        a, b = plain.step(actions), wide.step(actions)
        for x, y in zip(a[:3], b[:3]):
            np.testing.assert_array_equal(x, y)
    assert wide.episodes_ended == 0


def test_a_pickled_tube_steps_on_alike(plan) -> None:
    tube = PlanTube(ChainCartVecEnv(2, SWINGUP, seed=1), plan, 0.3)
    tube.reset()
    actions = np.ones((2, 1), dtype=np.float32)
    tube.step(actions)
    copy = pickle.loads(pickle.dumps(tube))
    assert copy.radius == 0.3
    for _ in range(40):
        a, b = tube.step(actions), copy.step(actions)
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[2], b[2])
    assert copy.episodes_ended == tube.episodes_ended > 0


@pytest.mark.parametrize("bad", [-0.5, float("nan"), float("inf"), True, "1"])
def test_a_bad_radius_names_itself(bad) -> None:
    with pytest.raises(InvalidInputError, match=r"plan tube = .*: expected a finite number >= 0"):
        check_plan_tube(bad)
    with pytest.raises(InvalidInputError, match=r"plan tube = "):
        Shaping(plan_tube=bad)


def test_the_wrapper_refuses_a_radius_of_zero(plan) -> None:
    assert not Shaping(plan_tube=0.0)  # the setting's 0 is no tube
    with pytest.raises(InvalidInputError, match=r"plan tube = 0.0 for the wrapper: expected a radius > 0"):
        PlanTube(ChainCartVecEnv(2, SWINGUP), plan, 0.0)


def test_the_tube_wraps_only_the_native_envs_and_plan_starts_wrap_it(plan) -> None:
    from stable_baselines3.common.vec_env import VecMonitor

    from chaincart_env.tools.compare.plan_start_envs import PlanStartEnvs

    with pytest.raises(InvalidInputError, match="the plan tube wraps the native ChainCartVecEnv: got VecMonitor"):
        PlanTube(VecMonitor(ChainCartVecEnv(2, SWINGUP)), plan, RADIUS)
    starts = PlanStartEnvs(PlanTube(ChainCartVecEnv(4, SWINGUP, seed=2), plan, RADIUS), plan, PlanStarts(1.0), seed=0)
    observations = starts.reset()
    on_plan = PlanPath(starts.unwrapped.model, plan).squared_distances(starts.unwrapped._batch.states()).min(axis=1)
    assert np.allclose(on_plan, 0.0) and observations.shape == (4, starts.observation_space.shape[0])


def test_compare_records_the_tube_and_refuses_it_without_one_plan() -> None:
    def shaping(scene: str, trainer: str = "sb3", **given) -> dict:
        settings = _training_settings(ChainCartConfig(scene=scene), ["ppo"], trainer, None, None, {}, {},
                                      imitation=False, curriculum=None, training_reward=None, shaping=given)
        return settings["ppo"]["shaping"]

    assert shaping("swingup-3", plan_tube=1.0)["plan_tube"] == 1.0
    assert shaping("swingup-3")["plan_tube"] == 0.0
    assert Shaping.from_record({"plan_bonus": 0.3}).plan_tube == 0.0  # a record from before the tube
    with pytest.raises(InvalidInputError, match="transitions-2"):
        shaping("transitions-2", plan_tube=1.0)
    with pytest.raises(InvalidInputError, match="--plan-tube 1.0 with --trainer rllib: expected the sb3"):
        shaping("swingup-3", trainer="rllib", plan_tube=1.0)


def test_the_command_line_refuses_a_negative_radius(tmp_path, capsys) -> None:
    with pytest.raises(SystemExit):
        main(["compare", "--plan-tube", "-1", "--out", str(tmp_path)])
    assert "plan tube = -1.0: expected a finite number >= 0" in capsys.readouterr().err


def _tiny_run(directory, radius: float):
    from chaincart_env.tools.compare.training import train

    return train(SWINGUP, timesteps=384, num_envs=4, seed=5, directory=directory, eval_seeds=[1_000_000],
                 eval_every=192, checkpoint_every=10_000, progress_bar=False,
                 hyperparameters={"n_steps": 32, "batch_size": 64, "policy_kwargs": "dict(net_arch=[16])"},
                 curriculum=PlanStarts(0.5), shaping=Shaping(plan_tube=radius))


def _rows(path):
    with path.open(newline="") as file:
        return [{k: v for k, v in row.items() if k != "wall_time_s"} for row in csv.DictReader(file)]


def test_a_tube_run_is_seeded_and_logs_the_episodes_it_ended(tmp_path) -> None:
    runs = [_tiny_run(tmp_path / name, 0.3) for name in ("a", "b")]
    parameters = [np.concatenate([p.detach().numpy().ravel() for p in r.model.policy.parameters()]) for r in runs]
    np.testing.assert_array_equal(parameters[0], parameters[1])
    rows = _rows(tmp_path / "a" / "training_episodes.csv")
    assert rows == _rows(tmp_path / "b" / "training_episodes.csv")
    left = [row for row in rows if row[LEFT_PLAN] == "1"]
    assert left and all(int(row["length"]) < SWINGUP.max_episode_steps and row["fell"] == "0" for row in left)
    _tiny_run(tmp_path / "c", 0.0)
    untubed = _rows(tmp_path / "c" / "training_episodes.csv")
    assert all(row[LEFT_PLAN] == "0" for row in untubed) and len(untubed) < len(rows)
