"""The plan-start curriculum: its settings and options are checked, its starts lie on the
planner's plan in the share asked, a run with it is seeded, and it survives a checkpoint."""

from __future__ import annotations

import csv
import json
import pickle

import numpy as np
import pytest

from chaincart_env import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.curriculum import FROZEN_CLIP, PlanStarts, plan_states, scene_curriculum

SWINGUP = ChainCartConfig(scene="swingup-2")


@pytest.mark.parametrize("fraction", [0.0, -0.5, 1.5, float("nan"), True, "half"])
def test_bad_fractions_are_named(fraction) -> None:
    with pytest.raises(InvalidInputError, match=r"plan-start fraction = .*expected a number in \(0, 1\]"):
        PlanStarts(fraction)


@pytest.mark.parametrize(
    "changes, named",
    [
        (dict(window=0.0), "plan-start window = 0.0"),
        (dict(threshold=2), "plan-start threshold = 2"),
        (dict(judged=0), "plan-start judged = 0"),
        (dict(judged=2.5), "plan-start judged = 2.5"),
        (dict(reverse="yes"), "plan-start reverse = 'yes'"),
        (dict(judge="upright"), "plan-start judge = 'upright': expected one of success, held"),
        (dict(reverse=True, freeze_statistics=1), "plan-start freeze_statistics = 1: expected true or false"),
        (dict(freeze_statistics=True), "plan-start freeze_statistics = True without reverse"),
        (dict(reverse=True, judged_starts="last"), "plan-start judged_starts = 'last': expected one of window, newest"),
        (dict(judged_starts="newest"), "plan-start judged_starts = 'newest' without reverse"),
    ],
)
def test_bad_reverse_settings_are_named(changes, named) -> None:
    with pytest.raises(InvalidInputError, match=named):
        PlanStarts(**changes)


def test_settings_round_trip_through_their_record() -> None:
    assert PlanStarts.from_record(PlanStarts(0.3).record()) == PlanStarts(0.3)
    reverse = PlanStarts(0.8, reverse=True, window=0.2, threshold=0.4, judged=10)
    assert PlanStarts.from_record(json.loads(json.dumps(reverse.record()))) == reverse
    held = PlanStarts(reverse=True, judge="held", freeze_statistics=True)
    assert PlanStarts.from_record(json.loads(json.dumps(held.record()))) == held
    newest = PlanStarts(reverse=True, judge="held", judged_starts="newest")
    assert PlanStarts.from_record(json.loads(json.dumps(newest.record()))) == newest
    older = {key: value for key, value in PlanStarts(reverse=True).record().items()
             if key not in ("freeze_statistics", "judged_starts")}  # fmt: skip
    assert PlanStarts.from_record(older) == PlanStarts(reverse=True)  # a record written before the setting existed
    with pytest.raises(InvalidInputError, match="expected kind 'plan'"):
        PlanStarts.from_record({"kind": "reverse", "fraction": 0.3})


@pytest.fixture(scope="module")
def states() -> np.ndarray:
    return plan_states(SWINGUP)


def test_the_plan_runs_from_hanging_to_upright(states) -> None:
    from chaincart_env.policies.settings import nearest_equilibrium

    model = SWINGUP.make_model()
    assert states.ndim == 2 and states.shape[0] > 50
    assert nearest_equilibrium(model, states[0]) == (1, 1)  # both links down
    assert nearest_equilibrium(model, states[-1]) == (-1, -1)  # both links up


def _on_plan(state: np.ndarray, states: np.ndarray) -> bool:
    return bool(np.min(np.max(np.abs(states - state), axis=1)) < 1e-12)


def test_every_start_lies_on_the_plan_with_fraction_one(states) -> None:
    from chaincart_env.sb3 import ChainCartVecEnv
    from chaincart_env.tools.compare.plan_start_envs import PlanStartEnvs

    venv = PlanStartEnvs(ChainCartVecEnv(6, SWINGUP, seed=3), states, PlanStarts(1.0), seed=0)
    observations = venv.reset()
    model_states = venv.venv.get_attr("model_state")
    assert all(_on_plan(y, states) for y in model_states)
    np.testing.assert_array_equal(observations, venv.venv._batch.observations())
    assert venv.plan_episodes == 6


def test_a_share_of_the_episodes_starts_on_the_plan(states) -> None:
    from chaincart_env.sb3 import ChainCartVecEnv
    from chaincart_env.tools.compare.plan_start_envs import PlanStartEnvs

    venv = PlanStartEnvs(ChainCartVecEnv(400, SWINGUP, seed=3), states, PlanStarts(0.25), seed=1)
    venv.reset()
    on_plan = sum(_on_plan(y, states) for y in venv.venv.get_attr("model_state"))
    assert venv.plan_episodes == on_plan
    assert 60 <= on_plan <= 140  # binomial(400, 0.25): mean 100, sd 8.7
    steps = SWINGUP.max_episode_steps
    for _ in range(steps):  # every episode ends by the horizon
        _, _, dones, _ = venv.step(np.zeros((400, 1), dtype=np.float32))
    assert venv.plan_episodes > on_plan  # the episodes that ended restarted, some on the plan


def test_the_wrapper_pickles_and_continues_identically(states) -> None:
    from chaincart_env.sb3 import ChainCartVecEnv
    from chaincart_env.tools.compare.plan_start_envs import PlanStartEnvs

    venv = PlanStartEnvs(ChainCartVecEnv(8, SWINGUP, seed=3), states, PlanStarts(0.5, reverse=True, judged=4), seed=4)
    venv.reset()
    rng = np.random.default_rng(0)
    for _ in range(SWINGUP.max_episode_steps // 2):
        venv.step(rng.uniform(-1, 1, (8, 1)).astype(np.float32))
    copy = pickle.loads(pickle.dumps(venv))
    actions = rng.uniform(-1, 1, (SWINGUP.max_episode_steps, 8, 1)).astype(np.float32)
    for a in actions:
        first, second = venv.step(a), copy.step(a)
        np.testing.assert_array_equal(first[0], second[0])
        np.testing.assert_array_equal(first[2], second[2])
    assert copy.plan_episodes == venv.plan_episodes > 0
    assert copy.windows == venv.windows and copy.steps == venv.steps


def _tiny_run(directory, curriculum):
    from chaincart_env.tools.compare.training import train

    return train(SWINGUP, timesteps=256, num_envs=4, seed=5, directory=directory, eval_seeds=[1_000_000],
                 eval_every=128, checkpoint_every=10_000, progress_bar=False,
                 hyperparameters={"n_steps": 32, "batch_size": 64, "policy_kwargs": "dict(net_arch=[16])"},
                 normalize={"norm_obs": True, "norm_reward": False}, curriculum=curriculum)


def _rows(path):
    with path.open(newline="") as file:
        return [{k: v for k, v in row.items() if k != "wall_time_s"} for row in csv.DictReader(file)]


def test_a_curriculum_run_is_seeded(tmp_path) -> None:
    results = [_tiny_run(tmp_path / name, PlanStarts(0.5)) for name in ("a", "b")]
    parameters = [np.concatenate([p.detach().numpy().ravel() for p in r.model.policy.parameters()]) for r in results]
    np.testing.assert_array_equal(parameters[0], parameters[1])
    assert _rows(tmp_path / "a" / "evaluations.csv") == _rows(tmp_path / "b" / "evaluations.csv")
    assert _rows(tmp_path / "a" / "training_episodes.csv") == _rows(tmp_path / "b" / "training_episodes.csv")
    without = _tiny_run(tmp_path / "c", None)
    other = np.concatenate([p.detach().numpy().ravel() for p in without.model.policy.parameters()])
    assert not np.array_equal(other, parameters[0])  # the curriculum changed what the agent saw


def test_compare_records_the_curriculum_and_refuses_it_where_it_cannot_serve() -> None:
    from chaincart_env.tools.compare.job import _training_settings

    chosen = _training_settings(SWINGUP, ["ppo", "sac"], "sb3", None, None, {}, {}, curriculum=PlanStarts(0.4))
    assert chosen["ppo"]["curriculum"] == chosen["sac"]["curriculum"] == PlanStarts(0.4).record()
    off = _training_settings(SWINGUP, ["ppo"], "sb3", None, None, {}, {}, curriculum=None)
    assert off["ppo"]["curriculum"] is None
    default = _training_settings(SWINGUP, ["ppo"], "sb3", None, None, {}, {})
    expected = scene_curriculum("swingup-2")
    assert default["ppo"]["curriculum"] == (None if expected is None else expected.record())
    with pytest.raises(InvalidInputError, match="transitions-2.*no single plan"):
        _training_settings(ChainCartConfig(scene="transitions-2"), ["ppo"], "sb3", None, None, {}, {},
                           curriculum=PlanStarts())
    with pytest.raises(InvalidInputError, match="--curriculum reverse with --trainer rllib"):
        _training_settings(SWINGUP, ["ppo"], "rllib", None, None, {}, {}, curriculum=PlanStarts(reverse=True))


@pytest.mark.parametrize(
    "argv, named",
    [
        (["--plan-fraction", "0.3"], "--plan-fraction 0.3 without --curriculum plan or reverse"),
        (["--curriculum", "none", "--plan-fraction", "0.3"], "without --curriculum plan or reverse"),
        (["--curriculum", "plan", "--plan-fraction", "1.5"], "plan-start fraction = 1.5"),
        (["--curriculum", "plan", "--scene", "transitions-2"], "no single plan"),
        (["--curriculum", "plan", "--curriculum-judge", "held"], "--curriculum-judge held without --curriculum reverse"),
        (["--curriculum", "reverse", "--curriculum-judge", "best"], "invalid choice: 'best'"),
        (["--curriculum-window", "0.05"], "--curriculum-window 0.05 without --curriculum reverse"),
        (["--curriculum", "reverse", "--curriculum-window", "0"], "plan-start window = 0.0"),
        (["--curriculum", "plan", "--curriculum-threshold", "0.3"], "--curriculum-threshold 0.3 without"),
        (["--curriculum", "reverse", "--curriculum-threshold", "1.5"], "plan-start threshold = 1.5"),
        (["--curriculum", "plan", "--curriculum-judged-starts", "newest"],
         "--curriculum-judged-starts newest without --curriculum reverse"),
        (["--curriculum", "reverse", "--curriculum-judged-starts", "last"], "invalid choice: 'last'"),
        (["--curriculum", "plan", "--curriculum-freeze-statistics"],
         "--curriculum-freeze-statistics without --curriculum reverse"),
        (["--curriculum", "reverse", "--curriculum-freeze-statistics", "--policies", "ppo"],
         "--curriculum-freeze-statistics for ppo, whose recipe (ppo.yml: ChainCart-swingup-2-v0) does not normalise"),
        (["--curriculum-spread-floor", "0.1"], "--curriculum-spread-floor 0.1 without --curriculum plan or reverse"),
        (["--curriculum", "none", "--curriculum-spread-floor", "0.1"], "without --curriculum plan or reverse"),
        (["--curriculum", "reverse", "--curriculum-spread-floor", "2"], "plan-start spread_floor = 2.0"),
        (["--curriculum", "plan", "--curriculum-spread-floor", "0.1", "--policies", "ppo"],
         "--curriculum-spread-floor for ppo, whose recipe (ppo.yml: ChainCart-swingup-2-v0) does not normalise"),
    ],
)
def test_the_command_line_names_bad_curriculum_options(argv, named, capsys, tmp_path) -> None:
    from chaincart_env.tools.compare.compare_cli import compare_main

    with pytest.raises(SystemExit):
        compare_main(["--scene", "swingup-2", "--out", str(tmp_path), *argv])
    assert named in capsys.readouterr().err


def test_the_command_line_options_become_the_curriculum_settings() -> None:
    from chaincart_env.tools.compare.compare_cli import _curriculum

    assert _curriculum("reverse", 0.75, "held", 0.02) == PlanStarts(0.75, reverse=True, window=0.02, judge="held")
    assert _curriculum("reverse", None, threshold=0.25) == PlanStarts(reverse=True, threshold=0.25)
    assert _curriculum("reverse", None) == PlanStarts(reverse=True)
    assert _curriculum("reverse", None, freeze_statistics=True) == PlanStarts(reverse=True, freeze_statistics=True)
    assert _curriculum("reverse", None, judged_starts="newest") == PlanStarts(reverse=True, judged_starts="newest")
    assert _curriculum("plan", None, spread_floor=0.1) == PlanStarts(spread_floor=0.1)
    assert _curriculum("reverse", 1.0, spread_floor=0.2) == PlanStarts(1.0, reverse=True, spread_floor=0.2)
    assert _curriculum(None, None) == "scene" and _curriculum("none", None) is None


def test_the_reverse_window_starts_at_the_end_and_widens_on_success(states) -> None:
    from chaincart_env.sb3 import ChainCartVecEnv
    from chaincart_env.tools.compare.plan_start_envs import PlanStartEnvs

    curriculum = PlanStarts(1.0, reverse=True, window=0.25, threshold=0.5, judged=8)
    venv = PlanStartEnvs(ChainCartVecEnv(8, SWINGUP, seed=3), states, curriculum, seed=2)
    venv.reset()
    last = states.shape[0] - 1
    late = states[int(0.75 * last):]
    assert all(_on_plan(y, late) for y in venv.venv.get_attr("model_state"))  # the last quarter only
    succeeded = [{"is_success": True}] * 8
    venv._judge(np.arange(8), succeeded)  # 8 of 8 plan-start episodes succeeded
    assert venv.window == 0.5 and venv.windows == [(0, 0.25), (0, 0.5)]
    venv._judge(np.arange(8), [{"is_success": i < 3} for i in range(8)])  # 3 of 8: below the threshold
    assert venv.window == 0.5 and len(venv.windows) == 2
    for _ in range(3):
        venv._judge(np.arange(8), succeeded)
    assert venv.window == 1.0 and venv._first_index() == 0


def test_a_held_judge_counts_the_episodes_that_end_at_the_time_limit_within_the_fall_limit(states) -> None:
    from chaincart_env.sb3 import ChainCartVecEnv
    from chaincart_env.tools.compare.plan_start_envs import PlanStartEnvs

    curriculum = PlanStarts(1.0, reverse=True, window=0.25, judged=4, judge="held")
    with pytest.raises(InvalidInputError, match="judge 'held' with the scene's fall_limit = 0: expected fall_limit > 0"):
        PlanStartEnvs(ChainCartVecEnv(4, SWINGUP, seed=3), states, curriculum, seed=2)
    falls = SWINGUP.replace(fall_limit=0.6)
    venv = PlanStartEnvs(ChainCartVecEnv(4, falls, seed=3), states, curriculum, seed=2)
    venv.reset()
    held = {"TimeLimit.truncated": True, "e_q": 0.3, "is_success": False}  # up, outside the success tolerance
    fell = {"TimeLimit.truncated": False, "e_q": 0.7, "is_success": False}
    down = {"TimeLimit.truncated": True, "e_q": 2.0, "is_success": False}  # never caught
    assert [venv._passed(info) for info in (held, fell, down)] == [True, False, False]
    venv._judge(np.arange(4), [held, held, fell, down])  # 2 of 4: the threshold
    assert venv.window == 0.5
    venv._judge(np.arange(4), [held, fell, fell, down])
    assert venv.window == 0.5


@pytest.mark.parametrize("judged_starts", ["newest", "window"])
def test_a_newest_band_judge_counts_only_the_starts_the_last_widening_added(states, judged_starts) -> None:
    from chaincart_env.sb3 import ChainCartVecEnv
    from chaincart_env.tools.compare.plan_start_envs import PlanStartEnvs

    curriculum = PlanStarts(1.0, reverse=True, window=0.25, judged=4, judged_starts=judged_starts)
    venv = PlanStartEnvs(ChainCartVecEnv(16, SWINGUP, seed=3), states, curriculum, seed=2)
    observations = venv.reset()
    first_window_start = venv._first_index()
    succeeded, failed = [{"is_success": True}] * 16, [{"is_success": False}] * 16
    venv._judge(np.arange(4), succeeded)  # before the first widening the whole window counts
    assert venv.window == 0.5
    newest = np.zeros(16, dtype=bool)
    while newest.sum() < 4 or (~newest).sum() < 4:  # fresh starts in both bands of the window
        venv._start_on_plan(np.arange(16), observations)
        newest = venv._start_index < first_window_start
    for i, k in enumerate(venv._start_index):  # the recorded start is where the env is
        np.testing.assert_array_equal(venv.venv.get_attr("model_state", indices=i)[0], states[k])
    older, added = np.flatnonzero(~newest)[:4], np.flatnonzero(newest)[:4]
    venv._judge(older, succeeded)  # four successes from the older band
    if judged_starts == "window":
        assert venv.window == 0.75  # enough on the whole window
        return
    assert venv.window == 0.5 and venv._judged == 0  # not counted
    venv._judge(added, failed)  # four failures from the newest band: judged, not passed
    assert venv.window == 0.5 and venv._judged == 0 and len(venv.windows) == 2
    second_window_start = venv._first_index()
    venv._judge(added, succeeded)
    assert venv.window == 0.75 and venv._newest_band_end() == second_window_start  # the band just added


def test_a_curriculum_log_is_written_beside_the_training(tmp_path) -> None:
    _tiny_run(tmp_path, PlanStarts(0.5, reverse=True))
    with (tmp_path / "curriculum.csv").open(newline="") as file:
        assert list(csv.DictReader(file)) == [{"env_steps": "0", "window": "0.1"}]


def test_a_training_reward_changes_the_training_envs_only(tmp_path) -> None:
    from chaincart_env.tools.compare.training import train

    result = train(SWINGUP, timesteps=128, num_envs=4, seed=5, directory=tmp_path, eval_seeds=[1_000_000],
                   eval_every=128, checkpoint_every=10_000, progress_bar=False,
                   hyperparameters={"n_steps": 32, "batch_size": 64, "policy_kwargs": "dict(net_arch=[16])"},
                   training_reward="exp")
    envs = result.model.get_env()
    while hasattr(envs, "venv"):
        envs = envs.venv
    assert envs.config.reward == "exp" and SWINGUP.reward == "tolerance"
    from chaincart_env.tools.compare.evaluation import rollout
    from chaincart_env.tools.compare.normalization import with_statistics

    with (tmp_path / "evaluations.csv").open(newline="") as file:
        last = list(csv.DictReader(file))[-1]
    policy = with_statistics(result.model, result.model.get_vec_normalize_env())
    on_scene = rollout(policy, "agent", SWINGUP, [1_000_000])  # the evaluation's start, on the scene's reward
    assert float(last["return_mean"]) == pytest.approx(float(np.mean(on_scene.returns)))


def test_an_unknown_training_reward_is_named_before_training() -> None:
    from chaincart_env.tools.compare.job import _training_settings

    with pytest.raises(InvalidInputError, match='unknown reward "bogus"'):
        _training_settings(SWINGUP, ["ppo"], "sb3", None, None, {}, {}, training_reward="bogus")
    chosen = _training_settings(SWINGUP, ["ppo"], "sb3", None, None, {}, {}, training_reward="exp")
    assert chosen["ppo"]["training_reward"] == "exp"


def test_compare_trains_the_swingup_recipe_with_its_plan_starts_and_training_reward(tmp_path) -> None:
    import json

    from chaincart_env.__main__ import main

    tiny = ["--timesteps", "256", "--num-envs", "4", "--eval-episodes", "2", "--eval-starts", "2",
            "--eval-every", "128", "--checkpoint-every", "128", "--sweep", "start_noise=0.05", "--no-progress",
            "--algo-kwarg", "n_steps=32", "--algo-kwarg", "batch_size=64"]
    assert main(["compare", "--scene", "swingup-2", "--policies", "ppo", *tiny, "--out", str(tmp_path)]) == 0
    training = json.loads((tmp_path / "run.json").read_text())["settings"]["training"]["ppo"]
    assert training["recipe"] == "ppo.yml: ChainCart-swingup-2-v0"
    assert PlanStarts.from_record(training["curriculum"]) == scene_curriculum("swingup-2")
    assert training["training_reward"] == "exp"
    with (tmp_path / "seed-0" / "curriculum.csv").open(newline="") as file:
        assert list(csv.DictReader(file)) == [{"env_steps": "0", "window": "1"}]


def test_plan_starts_wrap_only_the_native_envs(states) -> None:
    from stable_baselines3.common.vec_env import VecMonitor

    from chaincart_env.sb3 import ChainCartVecEnv
    from chaincart_env.tools.compare.plan_start_envs import PlanStartEnvs

    with pytest.raises(InvalidInputError, match=r"wrap the native ChainCartVecEnv \(or its plan tube\): got VecMonitor"):
        PlanStartEnvs(VecMonitor(ChainCartVecEnv(2, SWINGUP)), states, PlanStarts(), seed=0)
    with pytest.raises(InvalidInputError, match=r"plan states of shape \(8,\)"):
        PlanStartEnvs(ChainCartVecEnv(2, SWINGUP), states[0], PlanStarts(), seed=0)


def _freezing_agent(states):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from chaincart_env.sb3 import ChainCartVecEnv
    from chaincart_env.tools.compare.plan_start_envs import FreezeStatisticsOnWidening, PlanStartEnvs

    curriculum = PlanStarts(1.0, reverse=True, window=0.25, judged=4, freeze_statistics=True)
    plan = PlanStartEnvs(ChainCartVecEnv(4, SWINGUP, seed=3), states, curriculum, seed=2)
    envs = VecNormalize(VecMonitor(plan), norm_reward=False)
    model = PPO("MlpPolicy", envs, n_steps=16, batch_size=32, seed=0, device="cpu")
    callback = FreezeStatisticsOnWidening()
    callback.init_callback(model)
    return model, plan, envs, callback


def test_the_statistics_count_until_the_first_widening_and_then_hold(states) -> None:
    model, plan, envs, callback = _freezing_agent(states)
    rng = np.random.default_rng(0)
    envs.reset()
    for _ in range(5):
        envs.step(rng.uniform(-1, 1, (4, 1)).astype(np.float32))
        assert callback.on_step()
    assert envs.training and envs.clip_obs == 10.0  # still counting: the window has not widened
    plan._judge(np.arange(4), [{"is_success": True}] * 4)  # 4 of 4 passed: the window widens
    assert plan.window == 0.5
    callback.on_step()
    assert not envs.training and envs.clip_obs == FROZEN_CLIP
    mean, var, counted = envs.obs_rms.mean.copy(), envs.obs_rms.var.copy(), envs.obs_rms.count
    for _ in range(5):
        envs.step(rng.uniform(-1, 1, (4, 1)).astype(np.float32))
    np.testing.assert_array_equal(envs.obs_rms.mean, mean)
    np.testing.assert_array_equal(envs.obs_rms.var, var)
    assert envs.obs_rms.count == counted


def test_frozen_statistics_clip_far_observations_at_the_frozen_clip(states) -> None:
    _, plan, envs, callback = _freezing_agent(states)
    envs.reset()
    plan._judge(np.arange(4), [{"is_success": True}] * 4)
    callback.on_step()
    far = envs.obs_rms.mean + 50.0 * np.sqrt(envs.obs_rms.var + envs.epsilon)
    np.testing.assert_allclose(envs.normalize_obs(far[None])[0], 50.0, rtol=1e-9)  # beyond SB3's 10, within 100
    farther = envs.obs_rms.mean + 500.0 * np.sqrt(envs.obs_rms.var + envs.epsilon)
    np.testing.assert_array_equal(envs.normalize_obs(farther[None])[0], FROZEN_CLIP)


def test_a_run_freezing_its_statistics_trains_and_saves_them_frozen(tmp_path) -> None:
    from chaincart_env.tools.compare.normalization import load_statistics, save_agent
    from chaincart_env.tools.compare.plan_start_envs import plan_start_envs_of
    from chaincart_env.tools.compare.training import train

    # Short episodes that never fall (no e_q exceeds 7): every plan-start episode is held, so the window widens.
    always_held = SWINGUP.replace(max_episode_steps=16, fall_limit=7.0)

    def run(directory, freeze):
        curriculum = PlanStarts(1.0, reverse=True, window=0.25, judged=4, judge="held", freeze_statistics=freeze)
        return train(always_held, timesteps=256, num_envs=4, seed=5, directory=directory, eval_seeds=[1_000_000],
                     eval_every=128, checkpoint_every=10_000, progress_bar=False,
                     hyperparameters={"n_steps": 32, "batch_size": 64, "policy_kwargs": "dict(net_arch=[16])"},
                     normalize={"norm_obs": True, "norm_reward": False}, curriculum=curriculum)

    result = run(tmp_path, True)
    assert len(plan_start_envs_of(result.model.get_env()).windows) > 1  # the window widened
    statistics = result.model.get_vec_normalize_env()
    assert not statistics.training and statistics.clip_obs == FROZEN_CLIP
    save_agent(result.model, tmp_path / "agent.zip")
    saved = load_statistics(tmp_path / "agent.zip")  # a saved agent normalises as it trained
    assert saved is not None and not saved.training and saved.clip_obs == FROZEN_CLIP
    without = run(tmp_path / "running", False)
    assert len(plan_start_envs_of(without.model.get_env()).windows) > 1
    assert without.model.get_vec_normalize_env().training  # without the setting the statistics keep counting


def test_freezing_needs_a_recipe_that_normalises(tmp_path) -> None:
    from chaincart_env.tools.compare.training import train

    with pytest.raises(InvalidInputError, match="freezing the observation statistics with ppo's recipe, which does not"):
        train(SWINGUP, timesteps=64, num_envs=2, seed=5, directory=tmp_path, eval_seeds=[1_000_000],
              eval_every=64, checkpoint_every=10_000, progress_bar=False,
              curriculum=PlanStarts(1.0, reverse=True, freeze_statistics=True))


def test_statistics_fixed_before_the_widening_still_take_the_frozen_clip(states) -> None:
    _, plan, envs, callback = _freezing_agent(states)
    envs.reset()
    envs.training = False  # fixed from the start, as after an imitation
    callback.on_step()
    assert envs.clip_obs == 10.0  # nothing changes before the first widening
    plan._judge(np.arange(4), [{"is_success": True}] * 4)
    callback.on_step()
    assert not envs.training and envs.clip_obs == FROZEN_CLIP
