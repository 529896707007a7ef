"""Shipped pretrained agents: the numpy forward pass equals SB3's deterministic
``predict`` (SB3 itself the oracle, with VecNormalize statistics applied as SB3 applies
them), every shipped agent loads from plain arrays without torch and succeeds where its
record says, the shipped data keeps to its budget, the export command writes what loads,
and every ``--policy``/``--policies`` slot (animate, compare, evaluate, leaderboard)
takes ``pretrained:<scene>/<name>``."""

from __future__ import annotations

import csv
import json
import pathlib
import re
import subprocess
import sys
from typing import Any

import numpy as np
import pytest

import chaincart_env
from chaincart_env import ChainCartConfig, InvalidInputError
from chaincart_env.__main__ import main
from chaincart_env.pretrained_agents import (
    AGENTS_DIR,
    PretrainedPolicy,
    PretrainedSceneWarning,
    load_agent,
    parse_pretrained_slot,
    pretrained,
    shipped_agents,
)  # fmt: skip
from chaincart_env.tools.compare.evaluation import rollout
from chaincart_env.tools.controllers import parse_controllers
from chaincart_env.tools.export_agent import TOLERANCE, measure_success

ROOT = pathlib.Path(__file__).resolve().parents[2]
SLOT = "pretrained:inverted-2/ppo"
#: All shipped agents together stay under this many bytes.
BUDGET = 10 * 1024 * 1024
SHIPPED = [(scene, name) for scene, names in shipped_agents().items() for name in names]


def read_csv(path: pathlib.Path) -> list[dict[str, str]]:
    with path.open(newline="") as file:
        return list(csv.DictReader(file))


# -- the forward pass against SB3 ---------------------------------------------------------


def _sb3_model(algorithm: str, policy_kwargs: dict[str, Any], env: Any = None) -> Any:
    """An SB3 model on inverted-2 (or on ``env``) whose weights are redrawn (SB3's
    initial output layer is nearly zero, which would make any forward pass look right)."""
    import gymnasium
    import torch

    sb3 = pytest.importorskip("stable_baselines3")
    if algorithm == "TQC":
        algorithm_class = pytest.importorskip("sb3_contrib").TQC
    else:
        algorithm_class = getattr(sb3, algorithm)
    options = {} if algorithm in ("PPO", "A2C") else {"buffer_size": 100, "learning_starts": 0}
    env = gymnasium.make("ChainCart-inverted-2-v0") if env is None else env
    model = algorithm_class("MlpPolicy", env, policy_kwargs=policy_kwargs, seed=0, device="cpu", **options)
    generator = torch.Generator().manual_seed(1)
    with torch.no_grad():
        for parameter in model.policy.parameters():
            # Weights of unit gain per layer (pre-activations of order one, nothing saturated).
            scale = 1.5 / np.sqrt(parameter.shape[-1]) if parameter.ndim == 2 else 0.3
            parameter.copy_(torch.randn(parameter.shape, generator=generator) * scale)
    return model


def _statistics(size: int, seed: int) -> Any:
    """VecNormalize statistics of ``size`` observations, drawn (no env stepped)."""
    import gymnasium
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    statistics = VecNormalize(DummyVecEnv([lambda: gymnasium.make("ChainCart-inverted-2-v0")]), norm_obs=True,
                              norm_reward=False, clip_obs=3.0)
    rng = np.random.default_rng(seed)
    rms: Any = statistics.obs_rms
    rms.mean, rms.var = rng.normal(0, 1, size), rng.uniform(0.01, 4, size)
    return statistics


def _agent(model: Any, statistics: Any) -> PretrainedPolicy:
    from chaincart_env.tools.export_agent import agent_record

    record, arrays = agent_record(model, statistics, ChainCartConfig(scene="inverted-2"), "test")
    # Through the files, as an agent is shipped.
    return PretrainedPolicy(json.loads(json.dumps(record)), arrays)


def _policy_kwargs(case: str) -> dict[str, Any]:
    from torch import nn

    cases: dict[str, dict[str, Any]] = {
        "ppo-64": dict(net_arch=[64, 64]),
        "ppo-256": dict(net_arch=[256, 256]),
        "ppo-separate-relu": dict(net_arch=dict(pi=[32, 16], vf=[64]), activation_fn=nn.ReLU,
                                  share_features_extractor=False),
        "ppo-leaky": dict(net_arch=[16, 16], activation_fn=nn.LeakyReLU),
        "a2c-elu": dict(net_arch=[32], activation_fn=nn.ELU),
        "a2c-silu": dict(net_arch=[24, 24], activation_fn=nn.SiLU),
        "sac": dict(net_arch=[64, 64]),
        "tqc": dict(net_arch=[64, 64]),
        "td3": dict(net_arch=[64, 64]),
    }
    return cases[case]


CASES = [
    ("PPO", "ppo-64", False), ("PPO", "ppo-64", True), ("PPO", "ppo-256", True), ("PPO", "ppo-separate-relu", False),
    ("PPO", "ppo-leaky", False), ("A2C", "a2c-elu", True), ("A2C", "a2c-silu", False), ("SAC", "sac", False),
    ("SAC", "sac", True), ("TQC", "tqc", True), ("TD3", "td3", True),
]  # fmt: skip


@pytest.mark.parametrize(("algorithm", "case", "normalized"), CASES)
def test_the_numpy_forward_pass_is_sb3s_deterministic_predict(algorithm: str, case: str, normalized: bool) -> None:
    model = _sb3_model(algorithm, _policy_kwargs(case))
    size = model.observation_space.shape[0]
    statistics = _statistics(size, seed=len(case)) if normalized else None
    agent = _agent(model, statistics)
    rng = np.random.default_rng(3)
    observations = rng.normal(0, 3, (500, size))  # wide enough to hit the clip of the statistics
    sb3_input = observations if statistics is None else statistics.normalize_obs(observations)
    expected, _ = model.predict(sb3_input, deterministic=True)
    actions, state = agent.predict(observations, state="kept")
    assert state == "kept" and actions.shape == expected.shape == (500, 1) and actions.dtype == np.float32
    # float32 throughout, as torch computes; sums in another order differ in the last bits.
    np.testing.assert_allclose(actions, expected, rtol=0, atol=TOLERANCE)
    # The actions vary and are not all at the bounds: the comparison says something.
    assert np.ptp(expected) > 0.1 and np.mean(np.abs(expected) < 0.999) > 0.05
    # One observation (not a batch) gives one action of the action space's shape, as SB3 does.
    single, _ = agent.predict(observations[0])
    expected_single, _ = model.predict(sb3_input[0], deterministic=True)
    assert single.shape == expected_single.shape == (1,)
    np.testing.assert_allclose(single, expected_single, rtol=0, atol=TOLERANCE)


def test_what_the_forward_pass_does_not_reproduce_is_refused_at_export() -> None:
    from torch import nn

    from chaincart_env.tools.export_agent import actor_arrays

    with pytest.raises(InvalidInputError, match="use_sde=True"):
        actor_arrays(_sb3_model("PPO", dict(net_arch=[8])).__class__(
            "MlpPolicy", "ChainCart-inverted-2-v0", use_sde=True, device="cpu"))
    with pytest.raises(InvalidInputError, match="activation GELU.*expected Tanh, ReLU"):
        actor_arrays(_sb3_model("PPO", dict(net_arch=[8], activation_fn=nn.GELU)))
    dqn = pytest.importorskip("stable_baselines3").DQN("MlpPolicy", "CartPole-v1", buffer_size=100, device="cpu")
    with pytest.raises(InvalidInputError, match="expected Box spaces"):
        actor_arrays(dqn)


# -- the shipped agents ---------------------------------------------------------------------


def test_an_agent_is_shipped_and_all_of_them_keep_to_the_budget() -> None:
    assert ("inverted-2", "ppo") in SHIPPED
    files = [p for p in AGENTS_DIR.rglob("*") if p.is_file()]
    assert {p.suffix for p in files} <= {".npz", ".json"}
    assert sum(p.stat().st_size for p in files) <= BUDGET


@pytest.mark.parametrize(("scene", "name"), SHIPPED)
def test_a_shipped_agent_is_plain_arrays_and_a_complete_record(scene: str, name: str) -> None:
    with np.load(AGENTS_DIR / scene / f"{name}.npz", allow_pickle=False) as archive:
        assert all(archive[key].dtype.kind == "f" for key in archive.files)
    agent = pretrained(scene, name)
    record = agent.record
    assert (record["scene"], record["name"], agent.label) == (scene, name, f"pretrained:{scene}/{name}")
    assert record["algorithm"] in ("PPO", "A2C", "SAC", "TQC", "TD3", "DDPG")
    assert record["network"]["hidden"] and record["network"]["activation"] in ("tanh", "relu", "elu", "leaky_relu", "silu")
    assert record["normalization"] is None or set(record["normalization"]) >= {"clip_obs", "epsilon"}
    training = record["training"]
    assert training["command"] and isinstance(training["seed"], int) and training["timesteps"] > 0
    assert training["git_commit"]
    success = record["success"]
    assert len(success["seeds"]) == len(success["outcomes"]) == success["episodes"]
    assert success["successes"] == sum(success["outcomes"])
    config = agent.config()
    assert config.scene == scene and agent.observation_shape == (config.obs_dim,)


@pytest.mark.parametrize(("scene", "name"), SHIPPED)
def test_a_shipped_agent_succeeds_where_its_record_says(scene: str, name: str) -> None:
    agent = pretrained(scene, name)
    success = agent.success
    seeds, outcomes = success["seeds"], success["outcomes"]
    # The first three starts and, when there is one, the first start it failed on.
    chosen = list(range(min(3, len(seeds)))) + [i for i, ok in enumerate(outcomes) if not ok][:1]
    assert measure_success(agent, agent.config(), [seeds[i] for i in chosen]) == [outcomes[i] for i in chosen]


def test_loading_a_shipped_agent_needs_no_torch() -> None:
    code = (
        "import sys, numpy as np, chaincart_env\n"
        "agent = chaincart_env.pretrained('inverted-2', 'ppo')\n"
        "env = chaincart_env.ChainCartEnv(agent.config())\n"
        "obs, _ = env.reset(seed=0)\n"
        "action, _ = agent.predict(obs)\n"
        "assert action.shape == (1,) and agent.predict(np.stack([obs] * 3))[0].shape == (3, 1)\n"
        "assert 'torch' not in sys.modules and 'stable_baselines3' not in sys.modules, 'torch imported'\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr


def test_the_package_exports_pretrained() -> None:
    assert "pretrained" in chaincart_env.__all__ and chaincart_env.pretrained is pretrained


# -- bad input ------------------------------------------------------------------------------


def test_an_agent_that_is_not_shipped_is_an_error_listing_those_that_are() -> None:
    with pytest.raises(InvalidInputError, match=r"swingup-2/nope is not shipped: shipped: .*inverted-2/ppo"):
        pretrained("swingup-2", "nope")
    with pytest.raises(InvalidInputError, match=r"pretrained:nope/ppo.*is not shipped.*inverted-2/ppo"):
        parse_controllers("lqr,pretrained:nope/ppo")
    with pytest.raises(InvalidInputError, match=r"pretrained agent scene '\.\./x'"):
        pretrained("../x", "ppo")


@pytest.mark.parametrize("slot", ["pretrained:inverted-2", "pretrained:/ppo", "pretrained:inverted-2/", "pretrained:a/b/c"])
def test_a_bad_slot_says_what_was_expected(slot: str) -> None:
    with pytest.raises(InvalidInputError, match=r"expected pretrained:<scene>/<name>, e\.g\. pretrained:inverted-2/ppo"):
        parse_pretrained_slot(slot)


def test_observations_and_scenes_are_checked() -> None:
    agent = pretrained("inverted-2", "ppo")
    with pytest.raises(InvalidInputError, match=r"observation of shape \(3,\): expected \(8,\) or a batch"):
        agent.predict(np.zeros(3))
    with pytest.raises(InvalidInputError, match="deterministic=False"):
        agent.predict(np.zeros(agent.observation_shape), deterministic=False)
    # Other spaces: the network cannot read them.
    with pytest.raises(InvalidInputError, match="scene 'inverted-1' observes"):
        agent.check_config(ChainCartConfig(scene="inverted-1"))
    # The same spaces on another scene: it runs, with a warning that its record is not for it.
    with pytest.warns(PretrainedSceneWarning, match="not 'inverted-2-randomized'"):
        agent.check_config(ChainCartConfig(scene="inverted-2-randomized"))


def test_a_tampered_agent_is_refused(tmp_path: pathlib.Path) -> None:
    weights, record = AGENTS_DIR / "inverted-2" / "ppo.npz", AGENTS_DIR / "inverted-2" / "ppo.json"
    data = json.loads(record.read_text())
    data["network"]["hidden"] = [7]
    (tmp_path / "a.json").write_text(json.dumps(data))
    with pytest.raises(InvalidInputError, match=r"layer hidden.0 .*expected hidden.0.weight of shape \(7, 8\)"):
        load_agent(weights, tmp_path / "a.json")
    # An object array would need unpickling: np.load refuses it.
    np.savez(tmp_path / "b.npz", **{"hidden.0.weight": np.array([{"x": 1}], dtype=object)})  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="expected a plain .npz"):
        load_agent(tmp_path / "b.npz", record)


# -- the export command ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def saved_run(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    """A training run's folder as compare writes it (untrained PPO, with statistics)."""
    folder = tmp_path_factory.mktemp("run") / "seed-3"
    folder.mkdir()
    model = _sb3_model("PPO", dict(net_arch=[16, 16]))
    model.save(folder / "model.zip")
    _statistics(model.observation_space.shape[0], seed=5).save(str(folder / "vecnormalize.pkl"))
    (folder / "config.json").write_text(json.dumps(ChainCartConfig(scene="inverted-2", max_episode_steps=30).to_dict()))
    (folder / "run.json").write_text(json.dumps({"algo": "ppo", "seed": 3, "timesteps": 64, "trainer": "sb3"}))
    return folder


def test_export_writes_an_agent_that_loads_and_acts_as_the_saved_model(
    saved_run: pathlib.Path, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from stable_baselines3 import PPO

    from chaincart_env.tools.compare.normalization import load_statistics

    out = tmp_path / "agents"
    assert main(["export-agent", str(saved_run), "--name", "tiny", "--out-dir", str(out), "--episodes", "2",
                 "--first-seed", "4"]) == 0  # fmt: skip
    assert "use it as pretrained:inverted-2/tiny" in capsys.readouterr().out
    record = json.loads((out / "inverted-2" / "tiny.json").read_text())
    assert record["training"]["seed"] == 3 and record["training"]["command"].startswith("python -m chaincart_env")
    assert record["success"]["seeds"] == [4, 5] and record["config"]["max_episode_steps"] == 30
    assert record["normalization"]["clip_obs"] == 3.0 and record["network"]["hidden"] == [16, 16]
    agent = load_agent(out / "inverted-2" / "tiny.npz", out / "inverted-2" / "tiny.json")
    model, statistics = PPO.load(saved_run / "model.zip", device="cpu"), load_statistics(saved_run / "model.zip")
    assert statistics is not None
    observations = np.random.default_rng(0).normal(0, 2, (64, 8))
    expected, _ = model.predict(statistics.normalize_obs(observations), deterministic=True)
    np.testing.assert_allclose(agent.predict(observations)[0], expected, rtol=0, atol=TOLERANCE)
    # The recorded outcomes are those of the agent on its own starts.
    assert measure_success(agent, agent.config(), [4, 5]) == record["success"]["outcomes"]
    # An agent of that name is not replaced unless asked.
    with pytest.raises(SystemExit):
        main(["export-agent", str(saved_run), "--name", "tiny", "--out-dir", str(out), "--episodes", "1"])
    assert "exists: expected a new name, or --force" in capsys.readouterr().err
    assert main(["export-agent", str(saved_run), "--name", "tiny", "--out-dir", str(out), "--episodes", "1",
                 "--force"]) == 0  # fmt: skip


def test_export_checks_its_input(saved_run: pathlib.Path, tmp_path: pathlib.Path, capsys) -> None:
    run = str(saved_run)
    for args, message in (
        ([run, "--scene", "swingup-2", "--name", "x"], "--scene 'swingup-2': the run at .* was trained on scene 'inverted-2'"),
        ([run, "--name", "Bad Name"], "--name 'Bad Name': expected lower-case letters"),
        ([run, "--name", "x", "--vecnormalize", str(tmp_path / "none.pkl")], "--vecnormalize .*none.pkl: the file does not"),
        ([str(saved_run.parent), "--name", "x"], r"holds no model.zip: expected a training run's folder \(seed-<s>/"),
    ):
        with pytest.raises(SystemExit):
            main(["export-agent", *args, "--out-dir", str(tmp_path), "--episodes", "1"])
        assert re.search(message, capsys.readouterr().err), message


@pytest.mark.parametrize("k, timed, residual", [(2, False, False), (1, True, False), (1, True, True)])
def test_an_agent_with_history_is_exported_and_keeps_its_history_as_sb3s_wrappers_do(
    tmp_path: pathlib.Path, k: int, timed: bool, residual: bool
) -> None:
    import gymnasium

    from chaincart_env.elapsed_time import ElapsedTimeObservation
    from chaincart_env.history import HistoryObservation
    from chaincart_env.residual import RESIDUAL_ATTRIBUTE, ResidualAction, on_plain_env

    folder = tmp_path / "history-run"
    folder.mkdir()
    config = ChainCartConfig(scene="inverted-2", max_episode_steps=12)
    env: Any = gymnasium.make("ChainCart-inverted-2-v0", max_episode_steps=12)
    if residual:  # the base's command first, as the recipes lay it out
        env = ResidualAction(env, scale=0.5)
    env = HistoryObservation(env, k)
    if timed:  # the elapsed time after the history, as the recipes lay it out
        env = ElapsedTimeObservation(env)
    model = _sb3_model("PPO", dict(net_arch=[16, 16]), env)
    if residual:  # as compare's training records it
        setattr(model, RESIDUAL_ATTRIBUTE, {"scale": 0.5, "config": config.to_dict()})
    model.save(folder / "model.zip")
    (folder / "config.json").write_text(json.dumps(config.to_dict()))
    assert main(["export-agent", str(folder), "--name", "hist", "--out-dir", str(tmp_path / "agents"),
                 "--episodes", "2"]) == 0  # fmt: skip
    agent = load_agent(tmp_path / "agents" / "inverted-2" / "hist.npz", tmp_path / "agents" / "inverted-2" / "hist.json")
    assert agent.history == k and agent.record["history"] == k
    assert agent.elapsed_time == agent.record["elapsed_time"] == (12 if timed else 0)
    assert agent.observation_shape == (8,) and agent.input_shape == (8 + residual + k * (9 + residual) + timed,)
    assert agent.residual == (agent.record["residual"] if residual else None)
    assert (agent.record["residual"] or {}).get("scale") == (0.5 if residual else None)
    agent.check_config(config)  # acts on the scene's plain observations
    # Two envs over an episode end, against SB3's model behind the package's wrappers.
    reference = on_plain_env(model, env.unwrapped.observation_space, env.action_space, 12)
    batch = config.replace(start_noise=0.5).make_batch(2, "same_step")  # starts far enough to push
    obs = batch.reset([0, 1], None)
    starts, moved = np.ones(2, dtype=bool), False
    for _ in range(20):
        expected, _ = reference.predict(obs, episode_start=starts, deterministic=True)
        actual, _ = agent.predict(obs, episode_start=starts)
        np.testing.assert_allclose(actual, expected, rtol=0, atol=TOLERANCE)
        moved |= bool(np.abs(actual).max() > 0.1)
        obs, _, _, _, n_ended = batch.step(np.asarray(actual, dtype=np.float32))
        starts = batch.episode_arrays()[0].astype(bool) if n_ended else np.zeros(2, dtype=bool)
    assert moved  # actions worth comparing, not all near zero
    # reset() starts every history and clock afresh: the same first action as a new agent's.
    agent.reset()
    fresh = load_agent(tmp_path / "agents" / "inverted-2" / "hist.npz", tmp_path / "agents" / "inverted-2" / "hist.json")
    np.testing.assert_array_equal(agent.predict(obs[0])[0], fresh.predict(obs[0])[0])
    assert measure_success(agent, config, [0, 1]) == agent.success["outcomes"]


def test_a_record_with_a_bad_history_is_refused() -> None:
    model = _sb3_model("PPO", dict(net_arch=[8]))
    record, arrays = _record_and_arrays(model)
    for bad, message in ((-1, "history -1: expected an integer >= 0"), (True, "history True"),
                         (5, r"input of shape \(8,\) with history 5, elapsed_time 0 and residual False: expected obs \+ 5 "
                             r"\* \(obs \+ 1\)")):
        with pytest.raises(InvalidInputError, match=message):
            PretrainedPolicy({**record, "history": bad}, arrays)
    for bad, message in ((-3, "elapsed_time -3: expected an integer >= 0"), (2.5, "elapsed_time 2.5")):
        with pytest.raises(InvalidInputError, match=message):
            PretrainedPolicy({**record, "elapsed_time": bad}, arrays)
    for bad, message in (({"scale": 9, "config": {}}, "residual: residual scale = 9"),
                         ({"scale": 0.2}, "residual: chaincart_residual = ")):
        with pytest.raises(InvalidInputError, match=message):
            PretrainedPolicy({**record, "residual": bad}, arrays)


def _record_and_arrays(model: Any) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    from chaincart_env.tools.export_agent import agent_record

    record, arrays = agent_record(model, None, ChainCartConfig(scene="inverted-2"), "test")
    return json.loads(json.dumps(record)), arrays


# -- the slots of the commands --------------------------------------------------------------------


def test_animate_takes_a_shipped_agent_and_its_scene(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "a.gif"
    assert main(["animate", "--policy", SLOT, "--policy", "lqr", "--steps", "3", "--out", str(out), "--width", "40",
                 "--height", "20"]) == 0  # fmt: skip
    text = capsys.readouterr().out
    assert out.stat().st_size > 0 and f"{SLOT}: return" in text and "lqr: return" in text
    with pytest.raises(SystemExit):
        main(["animate", "--policy", SLOT, "--scene", "inverted-1", "--steps", "2", "--out", str(tmp_path / "b.gif")])
    assert "scene 'inverted-1' observes (5,)" in capsys.readouterr().err


FAST = ["--eval-episodes", "2", "--set", "max_episode_steps=40", "--sweep", "start_noise=0.05", "--no-progress"]


def test_compare_and_evaluate_take_a_shipped_agent(tmp_path: pathlib.Path) -> None:
    out = tmp_path / "run"
    assert main(["compare", "--policies", f"{SLOT},lqr", "--eval-seed", "3", *FAST, "--out", str(out)]) == 0
    rows = read_csv(out / "comparison.csv")
    assert [row["policy"] for row in rows] == [f"{SLOT} (seed 0)", "LQR"]
    config = ChainCartConfig(scene="inverted-2", max_episode_steps=40)
    run = rollout(pretrained("inverted-2", "ppo"), SLOT, config, [3, 4])
    assert float(rows[0]["return_mean"]) == pytest.approx(float(np.mean(run.returns)), rel=1e-12)
    assert f"{SLOT} (1 training seed) against LQR" in (out / "report.md").read_text()
    # The study re-evaluates with its shipped agent.
    assert main(["evaluate", str(out), "--out", str(tmp_path / "again")]) == 0
    assert read_csv(tmp_path / "again" / "comparison.csv") == rows
    # evaluate on the agent alone: its own scene, from the starts its record was measured on.
    alone = tmp_path / "alone"
    assert main(["evaluate", SLOT, "--eval-episodes", "2", "--out", str(alone)]) == 0
    agent = pretrained("inverted-2", "ppo")
    mine = read_csv(alone / "comparison.csv")[0]
    assert mine["policy"] == f"{SLOT} (seed 0)"
    assert float(mine["success_rate"]) == pytest.approx(np.mean(agent.success["outcomes"][:2]))


def test_compare_refuses_a_shipped_agent_of_other_spaces(capsys: pytest.CaptureFixture[str], tmp_path) -> None:
    with pytest.raises(SystemExit):
        main(["compare", "--scene", "inverted-1", "--policies", SLOT, *FAST, "--out", str(tmp_path)])
    assert "scene 'inverted-1' observes (5,)" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["evaluate", "pretrained:inverted-2/nope", "--out", str(tmp_path)])
    assert "inverted-2/nope is not shipped" in capsys.readouterr().err


def test_the_leaderboard_scores_a_shipped_agent_on_the_scenes_with_its_spaces(tmp_path: pathlib.Path) -> None:
    out = tmp_path / "board"
    argv = ["leaderboard", "--scenes", "inverted-2,inverted-1", "--policies", f"{SLOT},lqr", "--quick", "--axes",
            "mismatch", "--episodes", "1", "--out", str(out), "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    cells = read_csv(out / "cells.csv")
    assert {(c["scene"], c["controller"]) for c in cells} == {("inverted-2", SLOT), ("inverted-2", "lqr"),
                                                              ("inverted-1", "lqr")}
    assert "not scored" in (out / "leaderboard.md").read_text()
