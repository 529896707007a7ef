"""The study takes any set of controllers (``compare --policies``; bad names are in
``test_compare``'s bad-input cases): a study of model-based controllers alone, two
learned algorithms side by side in their own folders (evaluated, re-evaluated and
resumed), a run directory of the one-algorithm settings, and ``episode_start`` handed
to every policy rolled out."""

from __future__ import annotations

import csv
import json
import pathlib
import shutil
from typing import Any

import numpy as np
import pytest

from chaincart_env import ChainCartConfig, ChainCartEnv, LQRPolicy
from chaincart_env.__main__ import main
from chaincart_env.tools import controllers
from chaincart_env.tools.compare.evaluation import rollout
from chaincart_env.tools.compare.study import EVALUATION_FILES, TRAINING_EVALUATION_FILES
from chaincart_env.tools.controllers import Controller
from chaincart_env.tools.leaderboard.axes import parse_axes
from chaincart_env.tools.leaderboard.cells import Cell, run_cell

TABLES = ("comparison.csv", "episodes.csv", "sweeps.csv", "sweep_summary.csv")
FAST = [
    "--eval-episodes", "3", "--eval-seed", "7", "--set", "max_episode_steps=40", "--sweep", "start_noise=0.05,0.5",
    "--no-progress", "--torch-threads", "1",
]  # fmt: skip
TWO_LEARNED = [
    "--policies", "ppo,sac,lqr", "--timesteps", "128", "--num-envs", "2", "--eval-every", "128", "--eval-starts", "2",
    "--checkpoint-every", "128", "--algo-kwarg", "ppo:n_steps=64", "--algo-kwarg", "ppo:batch_size=64",
    "--algo-kwarg", "sac:learning_starts=50", "--algo-kwarg", "sac:batch_size=32", *FAST,
]  # fmt: skip


def read_csv(path: pathlib.Path) -> list[dict[str, str]]:
    with path.open(newline="") as file:
        return list(csv.DictReader(file))


class HalfLQR(LQRPolicy):
    """A model-based controller of this test: the LQR with half its gain."""

    @classmethod
    def from_env(cls, env: Any, **options: Any) -> "HalfLQR":  # type: ignore[override]
        lqr = LQRPolicy.from_env(env, **options)
        return cls(lqr.gain / 2, lqr.target, lqr.max_force, lqr.planar)


@pytest.fixture
def half_lqr(monkeypatch: pytest.MonkeyPatch) -> str:
    """``half`` registered as a model-based controller, the way the package's own are."""
    monkeypatch.setitem(controllers.CONTROLLERS, "half", Controller("half", "Half", __name__, "HalfLQR", learned=False))
    monkeypatch.setattr(controllers, "MODEL_BASED", (*controllers.MODEL_BASED, "half"))
    return "half"


def test_a_study_of_model_based_controllers_alone(half_lqr: str, tmp_path: pathlib.Path) -> None:
    out = tmp_path / "run"
    assert main(["compare", "--policies", f"{half_lqr},lqr", *FAST, "--out", str(out)]) == 0
    # Nothing trained: no training folder, no file about training.
    assert not list(out.glob("seed-*")) and not list(out.rglob("model.zip"))
    for name in EVALUATION_FILES:
        assert (out / name).is_file() == (name not in TRAINING_EVALUATION_FILES), name
    rows = read_csv(out / "comparison.csv")
    assert [row["policy"] for row in rows] == ["Half", "LQR"]
    # The same starts as a plain rollout of each controller.
    config = ChainCartConfig(max_episode_steps=40)
    for row, policy in zip(rows, (HalfLQR.from_env(ChainCartEnv(config)), LQRPolicy.from_env(ChainCartEnv(config)))):
        run = rollout(policy, row["policy"], config, [7, 8, 9])
        assert float(row["return_mean"]) == pytest.approx(float(np.mean(run.returns)), rel=1e-12)
    # The verdict weighs the other model-based controller against the best one.
    best = max(rows, key=lambda r: (float(r["success_rate"]), float(r["return_mean"])))["policy"]
    report = (out / "report.md").read_text()
    other = "Half" if best == "LQR" else "LQR"
    assert f"Baseline: {best}, the best model-based controller of this study" in report
    assert f"{other} (model-based) against {best}" in report and "Neither is trained" in report
    assert json.loads((out / "run.json").read_text())["seed_runs"] == {}
    assert main(["evaluate", str(out), "--out", str(tmp_path / "again")]) == 0
    for name in TABLES:
        assert (tmp_path / "again" / name).read_text() == (out / name).read_text(), name


def test_one_controller_alone_is_reported_as_such(tmp_path: pathlib.Path) -> None:
    assert main(["compare", "--policies", "lqr", *FAST, "--sweep", "mismatch=0,0.3", "--out", str(tmp_path)]) == 0
    # With a parameter gap in the sweeps the oracle LQR comes with the LQR; it is no baseline.
    assert [row["policy"] for row in read_csv(tmp_path / "comparison.csv")] == ["LQR", "LQR oracle"]
    assert "**Only LQR was evaluated**" in (tmp_path / "report.md").read_text()


@pytest.fixture(scope="module")
def two_learned(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    out = tmp_path_factory.mktemp("two") / "run"
    assert main(["compare", *TWO_LEARNED, "--out", str(out)]) == 0
    return out


def test_two_learned_algorithms_train_in_their_own_folders_and_face_the_same_baseline(two_learned: pathlib.Path) -> None:
    out = two_learned
    run = json.loads((out / "run.json").read_text())
    assert run["status"] == "done" and list(run["seed_runs"]) == ["ppo/0", "sac/0"]
    settings = run["settings"]
    assert settings["policies"] == ["ppo", "sac", "lqr"]
    assert settings["training"]["ppo"]["hyperparameters"]["n_steps"] == 64
    assert settings["training"]["sac"]["hyperparameters"] == {"learning_starts": 50, "batch_size": 32}
    assert not list(out.glob("seed-*"))
    for algo in ("ppo", "sac"):
        seed_run = json.loads((out / algo / "seed-0" / "run.json").read_text())
        assert seed_run["algo"] == algo and seed_run["timesteps_trained"] >= 128
        assert (out / algo / "seed-0" / "model.zip").is_file() and (out / algo / "seed-0" / "learning_curve.png").is_file()
    assert [row["policy"] for row in read_csv(out / "comparison.csv")] == [
        "PPO (seed 0)", "PPO best (seed 0)", "SAC (seed 0)", "SAC best (seed 0)", "LQR",
    ]
    assert [row["policy"] for row in read_csv(out / "seeds.csv")] == ["PPO", "PPO best", "SAC", "SAC best"]
    report = (out / "report.md").read_text()
    assert report.startswith("# PPO and SAC vs the paper's LQR")
    assert "PPO (1 training seed) against LQR" in report and "SAC (1 training seed) against LQR" in report
    assert "PPO, seed 0:" in report and "SAC, seed 0:" in report  # training notes
    for name in set(EVALUATION_FILES):
        assert (out / name).is_file(), name


def test_two_learned_algorithms_re_evaluate_whole_and_one_by_one(two_learned: pathlib.Path, tmp_path: pathlib.Path) -> None:
    assert main(["evaluate", str(two_learned), "--out", str(tmp_path / "all")]) == 0
    for name in TABLES + ("seeds.csv",):
        assert (tmp_path / "all" / name).read_text() == (two_learned / name).read_text(), name
    assert main(["evaluate", str(two_learned / "sac" / "seed-0"), "--out", str(tmp_path / "sac")]) == 0
    whole = read_csv(two_learned / "comparison.csv")
    assert read_csv(tmp_path / "sac" / "comparison.csv") == [r for r in whole if r["policy"].startswith(("SAC", "LQR"))]


def test_a_study_of_two_learned_algorithms_resumes_the_one_not_trained(
    two_learned: pathlib.Path, tmp_path: pathlib.Path
) -> None:
    out = tmp_path / "run"
    shutil.copytree(two_learned, out)
    # As if stopped before SAC trained: its record and folder gone.
    run = json.loads((out / "run.json").read_text())
    del run["seed_runs"]["sac/0"]
    run["status"] = "interrupted"
    (out / "run.json").write_text(json.dumps(run))
    shutil.rmtree(out / "sac")
    ppo_model = (out / "ppo" / "seed-0" / "model.zip").read_bytes()
    assert main(["compare", "--resume", str(out)]) == 0
    assert (out / "ppo" / "seed-0" / "model.zip").read_bytes() == ppo_model  # kept, not trained again
    assert list(json.loads((out / "run.json").read_text())["seed_runs"]) == ["ppo/0", "sac/0"]
    for name in TABLES:  # SAC trained again from its seed: the same agent, the same tables
        assert (out / name).read_text() == (two_learned / name).read_text(), name


def test_a_run_saved_before_several_policies_evaluates_as_before(two_learned: pathlib.Path, tmp_path: pathlib.Path) -> None:
    # The layout and settings of a one-algorithm run written before --policies: seed-<s>/,
    # seed_runs keyed by seed, the algorithm's training settings at the top level.
    old = tmp_path / "old"
    old.mkdir()
    shutil.copy(two_learned / "config.json", old / "config.json")
    shutil.copytree(two_learned / "ppo" / "seed-0", old / "seed-0")
    run = json.loads((two_learned / "run.json").read_text())
    settings = {k: v for k, v in run["settings"].items() if k not in ("policies", "training")}
    settings.update(algo="ppo", **{k: run["settings"]["training"]["ppo"][k]
                                   for k in ("timesteps", "num_envs", "hyperparameters")})  # fmt: skip
    (old / "run.json").write_text(json.dumps({**run, "settings": settings, "seed_runs": {"0": run["seed_runs"]["ppo/0"]}}))
    assert main(["evaluate", str(old), "--out", str(tmp_path / "again")]) == 0
    whole = read_csv(two_learned / "comparison.csv")
    assert read_csv(tmp_path / "again" / "comparison.csv") == [r for r in whole if not r["policy"].startswith("SAC")]
    assert main(["evaluate", str(old / "seed-0"), "--out", str(tmp_path / "seed")]) == 0
    assert read_csv(tmp_path / "seed" / "comparison.csv") == read_csv(tmp_path / "again" / "comparison.csv")


class EpisodeStarts:
    """A policy that records the ``episode_start`` it is given at every call; env i of
    n pushes steadily, harder the larger i, so that the cart leaves the track after a
    time of its own."""

    def __init__(self) -> None:
        self.calls: list[np.ndarray] = []

    def predict(self, obs: Any, state: Any = None, episode_start: Any = None, deterministic: bool = False) -> Any:
        self.calls.append(np.array(episode_start, dtype=bool))
        return np.linspace(0.4, 1.0, len(obs), dtype=np.float32).reshape(-1, 1), state


def test_every_rollout_tells_the_policy_where_episodes_begin() -> None:
    config = ChainCartConfig(scene="inverted-1", max_episode_steps=300)
    policy = EpisodeStarts()
    run = rollout(policy, "p", config, [3, 4, 5])
    assert run.terminated.all() and len(set(run.lengths.tolist())) == 3  # each env off the track at its own time
    calls = np.array(policy.calls)
    assert calls.shape == (int(run.lengths.max()), 3)
    for i, length in enumerate(run.lengths):
        # True on the first call and, the batch restarting an env at once, on the call
        # after its episode ended; false in between.
        expected = np.zeros(calls.shape[0], dtype=bool)
        expected[0] = True
        expected[length:length + 1] = True
        assert np.array_equal(calls[:, i], expected), i
    # The leaderboard's timed wrapper hands it on as well.
    recorder = EpisodeStarts()
    cell = Cell("inverted-1", "p", parse_axes("delay")[0], 0.0, seed=0, episodes=2)
    run_cell(cell, config, recorder)
    assert np.array(recorder.calls)[0].all() and not np.array(recorder.calls)[1].any()
