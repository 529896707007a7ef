"""The main job (``python -m chaincart_env compare`` / ``evaluate``): the whole
pipeline on a tiny budget, the evaluation against an independent single-env loop,
the LQR baseline on the default scene, save/reload reproducibility and CLI errors."""

from __future__ import annotations

import csv
import json
import math
import pathlib
import subprocess
import tempfile

import numpy as np
import pytest
from PIL import Image

from chaincart_env import ChainCartConfig, ChainCartEnv, LQRPolicy
from chaincart_env.__main__ import main
from chaincart_env.tools.compare.compare_cli import compare_main
from chaincart_env.tools.compare.evaluation import (
    EPISODE_COLUMNS,
    METRIC_COLUMNS,
    Rollouts,
    evaluate_policies,
    evaluation_seeds,
    rollout,
    settle_times,
)
from chaincart_env.tools.compare.filmstrip import DEFAULT_FRAMES, filmstrip_size
from chaincart_env.tools.compare.job import EVALUATION_FILES, OUTPUT_FILES, SEED_FILES
from chaincart_env.tools.compare.learning_curve import LEARNING_CURVE_COLUMNS
from chaincart_env.tools.compare.scene_options import parse_value
from chaincart_env.tools.compare.study_plots import FIGURE_SIZE_PX
from chaincart_env.tools.compare.training import TRAINING_EPISODE_COLUMNS

ROOT = pathlib.Path(__file__).resolve().parents[2]
EPISODE_STEPS = 40
MAX_FORCE = 20.0
# A budget of seconds: 2 envs, PPO rollouts of 64 steps, 40-step episodes, 3 starts,
# evaluations during training every 128 steps on 2 starts, one two-value sweep.
TINY = [
    "--timesteps", "256", "--num-envs", "2", "--eval-episodes", "3", "--eval-seed", "7",
    "--set", f"max_episode_steps={EPISODE_STEPS}", "--algo-kwarg", "n_steps=64", "--algo-kwarg", "batch_size=64",
    "--eval-every", "128", "--eval-starts", "2", "--checkpoint-every", "128", "--sweep", "start_noise=0.05,0.5",
    "--no-progress",
]  # fmt: skip


def read_csv(path: pathlib.Path) -> tuple[list[str], list[dict[str, str]]]:
    with path.open(newline="") as file:
        reader = csv.DictReader(file)
        return list(reader.fieldnames or []), list(reader)


@pytest.fixture(scope="module")
def tiny_run_and_temp(tmp_path_factory: pytest.TempPathFactory) -> tuple[pathlib.Path, pathlib.Path]:
    """The tiny study's folder, and the temporary directory it ran with (Python's
    ``tempfile`` pointed at a folder of its own)."""
    out, temp = tmp_path_factory.mktemp("compare"), tmp_path_factory.mktemp("tempdir")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(tempfile, "tempdir", str(temp))
        assert main(["compare", *TINY, "--out", str(out)]) == 0
    return out, temp


@pytest.fixture(scope="module")
def tiny_run(tiny_run_and_temp: tuple[pathlib.Path, pathlib.Path]) -> pathlib.Path:
    return tiny_run_and_temp[0]


def test_training_leaves_no_log_folders_in_the_temporary_directory(
    tiny_run_and_temp: tuple[pathlib.Path, pathlib.Path],
) -> None:
    # SB3 makes an SB3-<date> folder there at every learn() of a model without a logger.
    _, temp = tiny_run_and_temp
    assert not list(temp.glob("SB3-*"))


def test_compare_writes_every_output_with_sane_values(tiny_run: pathlib.Path) -> None:
    for name in OUTPUT_FILES:
        assert (tiny_run / name).is_file() and (tiny_run / name).stat().st_size > 0, name
    for name in SEED_FILES:
        assert (tiny_run / "seed-0" / name).is_file(), name

    columns, rows = read_csv(tiny_run / "comparison.csv")
    assert columns == list(METRIC_COLUMNS)
    assert [row["policy"] for row in rows] == ["PPO (seed 0)", "PPO best (seed 0)", "LQR"]
    for row in rows:
        assert int(row["episodes"]) == 3
        assert 0.0 <= float(row["success_rate"]) <= 1.0
        for key in ("return_mean", "return_std", "final_e_q_mean", "final_e_w_mean", "peak_force_mean",
                    "rms_force_mean"):  # fmt: skip
            assert math.isfinite(float(row[key])) and float(row[key]) >= 0.0, (key, row[key])
        assert float(row["return_mean"]) <= EPISODE_STEPS  # rewards are in (0, 1]
        assert float(row["rms_force_mean"]) <= float(row["peak_force_mean"]) <= MAX_FORCE + 1e-9
        settled = int(row["settled"])
        assert math.isnan(float(row["settle_time_mean"])) == (settled == 0)
        # Settling (as defined) happens exactly in the successful episodes.
        assert settled == round(float(row["success_rate"]) * 3)

    columns, episodes = read_csv(tiny_run / "episodes.csv")
    assert columns == list(EPISODE_COLUMNS) and len(episodes) == 9
    assert sorted({int(e["seed"]) for e in episodes}) == [7, 8, 9]
    for e in episodes:
        length = int(e["length"])
        assert 1 <= length <= EPISODE_STEPS
        assert 0.0 < float(e["return"]) <= length
        assert int(e["terminated"]) == (length < EPISODE_STEPS)
        if int(e["is_success"]):
            assert float(e["final_e_q"]) <= 0.1 and float(e["final_e_w"]) <= 0.5
            assert 0.0 <= float(e["settle_time"]) <= length * 0.02

    columns, train = read_csv(tiny_run / "seed-0" / "training_episodes.csv")
    assert columns == list(TRAINING_EPISODE_COLUMNS) and train
    steps = [int(r["timesteps"]) for r in train]
    assert steps == sorted(steps) and steps[-1] <= 256 + 64 * 2
    assert all(1 <= int(r["length"]) <= EPISODE_STEPS and int(r["is_success"]) in (0, 1) for r in train)
    columns, curve = read_csv(tiny_run / "seed-0" / "learning_curve.csv")
    assert columns == list(LEARNING_CURVE_COLUMNS) and curve
    assert sum(int(r["episodes"]) for r in curve) == len(train)
    assert all(0.0 <= float(r["success_rate"]) <= 1.0 and math.isfinite(float(r["return_mean"])) for r in curve)

    sizes = {"seed-0/learning_curve.png": FIGURE_SIZE_PX, "errors.png": FIGURE_SIZE_PX,
             "evaluation_curve.png": FIGURE_SIZE_PX, "sweep_start_noise.png": FIGURE_SIZE_PX,
             "filmstrip.png": filmstrip_size(2, DEFAULT_FRAMES)}  # fmt: skip
    for name, size in sizes.items():
        with Image.open(tiny_run / name) as image:
            image.load()
            assert image.format == "PNG" and image.size == size, name
            # Something is drawn: not a blank canvas.
            assert np.asarray(image.convert("L")).std() > 1.0, name

    config = json.loads((tiny_run / "config.json").read_text())
    assert ChainCartConfig(**config) == ChainCartConfig(max_episode_steps=EPISODE_STEPS)
    run = json.loads((tiny_run / "run.json").read_text())
    assert run["status"] == "done" and run["settings"]["seeds"] == [0]
    seed_run = json.loads((tiny_run / "seed-0" / "run.json").read_text())
    assert seed_run["algo"] == "ppo" and seed_run["eval_seed"] == 7 and seed_run["hyperparameters"]["n_steps"] == 64
    table = (tiny_run / "comparison.md").read_text()
    assert "| PPO (seed 0) | 3 |" in table and "| LQR | 3 |" in table
    # Evaluations during training: at 0, every 128 steps, and at the end (256 steps, 2 starts).
    _, evaluations = read_csv(tiny_run / "seed-0" / "evaluations.csv")
    assert [int(float(r["timesteps"])) for r in evaluations] == [0, 128, 256]
    assert all(float(r["episodes"]) == 2 for r in evaluations)
    # The sweep: every policy at both values on the same 3 starts.
    _, sweep = read_csv(tiny_run / "sweep_summary.csv")
    assert [(float(r["value"]), r["policy"]) for r in sweep] == [
        (v, p) for v in (0.05, 0.5) for p in ("PPO", "PPO best", "LQR")
    ]
    assert all(int(r["episodes"]) == 3 for r in sweep)
    report = (tiny_run / "report.md").read_text()
    assert "## Sweep: start perturbation" in report and "![summary](summary.png)" in report
    # The verdict first; one seed: no interval over seeds is claimed.
    assert report.index("## Verdict") < report.index("## Setup") < report.index("## On the evaluation starts")
    # The sweep value 0.05 is the starts' own setting: two distinct settings, not three.
    assert "PPO (1 training seed) against LQR, success rates at 2 distinct settings" in report
    assert "over seeds" not in report.replace("no interval over seeds", "")
    assert "PPO, one training seed: success" in report and "One seed gives no interval over seeds" in report


def test_evaluate_reproduces_the_comparison_from_the_saved_model(
    tiny_run: pathlib.Path, tmp_path: pathlib.Path
) -> None:
    assert main(["evaluate", str(tiny_run), "--out", str(tmp_path / "dir")]) == 0
    for name in EVALUATION_FILES:
        assert (tmp_path / "dir" / name).is_file(), name
    for name in ("comparison.csv", "episodes.csv", "sweeps.csv", "seeds.csv"):
        assert (tmp_path / "dir" / name).read_text() == (tiny_run / name).read_text(), name
    # One seed's model alone: the same rows for it and the LQR.
    assert main(["evaluate", str(tiny_run / "seed-0" / "model.zip"), "--out", str(tmp_path / "zip")]) == 0
    _, whole = read_csv(tiny_run / "comparison.csv")
    _, alone = read_csv(tmp_path / "zip" / "comparison.csv")
    assert alone == [row for row in whole if row["policy"] in ("PPO (seed 0)", "PPO best (seed 0)", "LQR")]


def test_a_reloaded_model_gives_identical_rollouts(tiny_run: pathlib.Path) -> None:
    from chaincart_env.tools.compare.policy_sources import load_run

    first, second = load_run(tiny_run / "seed-0"), load_run(tiny_run / "seed-0" / "model.zip")
    seeds = evaluation_seeds(100, 4)
    a = rollout(first.model, "PPO", first.config, seeds)
    b = rollout(second.model, "PPO", second.config, seeds)
    for key in ("returns", "lengths", "success", "e_q", "e_w", "force", "first_states"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key), err_msg=key)


def test_batched_evaluation_matches_a_plain_single_env_loop() -> None:
    # Oracle: the Gymnasium env stepped one episode at a time with the same policy.
    config = ChainCartConfig(start_noise=0.3, max_episode_steps=150)
    env = ChainCartEnv(config)
    lqr = LQRPolicy.from_env(env)
    seeds = [3, 4, 5, 6, 7, 8]
    run = rollout(lqr, "LQR", config, seeds)
    for i, seed in enumerate(seeds):
        obs, _ = env.reset(seed=seed)
        total, e_q, forces = 0.0, [env.model.errors(env.model_state, config.target_signs)[0]], []
        info: dict = {}
        for k in range(config.max_episode_steps):
            action = lqr.predict(obs)[0]
            forces.append(abs(float(np.clip(action[0], -1, 1))) * config.max_force)
            obs, reward, terminated, truncated, info = env.step(action)
            total += float(reward)
            e_q.append(env.model.errors(env.model_state, config.target_signs)[0])
            if terminated or truncated:
                break
        assert run.lengths[i] == k + 1
        assert run.terminated[i] == terminated and run.success[i] == info["is_success"]
        assert run.returns[i] == pytest.approx(total, rel=1e-9)
        np.testing.assert_allclose(run.e_q[i, : k + 2], e_q, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(run.force[i, : k + 1], forces, rtol=1e-9)
        assert np.isnan(run.e_q[i, k + 2 :]).all()
    assert run.terminated.any() and run.success.any()  # noise 0.3 gives both kinds of episode


def test_lqr_baseline_succeeds_on_the_default_scene_from_its_default_perturbations() -> None:
    config = ChainCartConfig()
    assert config.scene == "inverted-2" and config.start_noise > 0
    lqr = LQRPolicy.from_env(ChainCartEnv(config))
    _, episodes, (summary,) = evaluate_policies([("LQR", lqr)], config, evaluation_seeds(1_000_000, 20))
    assert summary["success_rate"] >= 0.9
    assert summary["settled"] >= 18 and 0.0 < summary["settle_time_mean"] < config.max_episode_steps * config.dt
    assert len({e["return"] for e in episodes}) == 20  # 20 different starts


def _rollouts(e_q: list[float], e_w: list[float], success: bool) -> Rollouts:
    steps = len(e_q) - 1
    return Rollouts(
        policy="p", dt=0.5, seeds=np.array([0]), returns=np.array([1.0]), lengths=np.array([steps]),
        success=np.array([success]), terminated=np.array([False]), e_q=np.array([e_q]), e_w=np.array([e_w]),
        force=np.zeros((1, steps)), first_states=np.zeros((steps + 1, 10)), first_forces=np.zeros((steps, 2)),
    )  # fmt: skip


def test_time_to_settle_is_the_first_time_after_which_both_errors_stay_inside() -> None:
    tol = (0.1, 0.5)
    # Outside at steps 0-1 (e_q), back inside at 2, out again at 3 (e_w), inside from step 4 on.
    run = _rollouts([0.3, 0.2, 0.05, 0.05, 0.01, 0.0], [0.1, 0.1, 0.1, 0.6, 0.4, 0.1], True)
    assert settle_times(run, tol)[0] == 4 * 0.5
    assert settle_times(_rollouts([0.05, 0.01], [0.1, 0.1], True), tol)[0] == 0.0
    assert np.isnan(settle_times(_rollouts([0.05, 0.01], [0.1, 0.1], False), tol)[0])


def test_cli_values_parse_to_config_values() -> None:
    assert parse_value("3") == 3 and parse_value("0.5") == 0.5
    assert parse_value("false") is False and parse_value("True") is True
    assert parse_value("-1,1") == (-1, 1) and parse_value("[0.5, 0.4]") == (0.5, 0.4)
    assert parse_value("inverted") == "inverted" and parse_value('{"q": 2}') == {"q": 2}
    # Infinity as Python writes it, alone, in a list, after a comma or signed; not in names or strings.
    assert parse_value("inf") == math.inf and parse_value("[200, inf]") == (200, math.inf)
    assert parse_value("200,Inf") == (200, math.inf) and parse_value("-infinity") == -math.inf
    assert parse_value("[200, Infinity]") == (200, math.inf)
    assert parse_value("info") == "info" and parse_value('{"view": "inf"}') == {"view": "inf"}


@pytest.mark.parametrize(
    "args, message",
    [
        (["--algo", "a2c"], "invalid choice: 'a2c'"),
        (["--timesteps", "-5"], "timesteps = -5: expected an integer >= 1"),
        (["--timesteps", "lots"], "timesteps = 'lots': expected an integer >= 1"),
        (["--num-envs", "0"], "num-envs = 0: expected an integer >= 1"),
        (["--set", "bogus=1"], "--set 'bogus=1': unknown config key \"bogus\": expected one of"),
        (["--set", "n-link=3"], 'unknown config key "n_link" (did you mean "n_links"?)'),
        (["--set", "n_links"], "expected key=value"),
        (["--scene", "nope"], 'unknown scene "nope"'),
        (["--n-links", "two"], "n_links = 'two': expected an integer"),
        (["--start-noise=-1"], "start_noise"),
        (["--algo-kwarg", "n_stepz=64"], "n_stepz"),
        (["--scene", "paper-fig1"], "lqr cannot serve scene 'paper-fig1'"),
        (["--seeds", "0,0"], "expected distinct integers"),
        (["--seeds", "1,x"], "seeds = '1,x'"),
        (["--seeds", "0", "--seed", "1"], "not allowed with argument"),
        (["--sweep", "speed=1,2"], "AXIS one of"),
        (["--sweep", "start_noise=0.1,-1"], "expected a finite number >= 0"),
        (["--sweep", "start_noise=0.1", "--sweep", "start_noise=0.2"], "given twice"),
        (["--eval-every", "0"], "eval-every = 0"),
        (["--checkpoint-every", "-3"], "checkpoint-every = -3"),
        (["--eval-starts", "0"], "eval-starts = 0"),
        (["--resume", "/nonexistent/run"], "expected a run directory of compare"),
        (["--policies", "ppo,dqn"], "--policies 'ppo,dqn': unknown controller 'dqn'"),
        (["--policies", "ppo,lqe"], "unknown controller 'lqe' (did you mean 'lqr'?)"),
        (["--policies", "lqr,ppo,LQR"], "--policies 'lqr,ppo,LQR': lqr given twice"),
        (["--policies", ","], "--policies ',': expected distinct names among ppo, sac, td3, ppo-robust, ppo-residual, lqr"),
        (["--policies", "ppo,lqr", "--algo", "sac"], "not allowed with argument"),
        (["--policies", "sac,lqr", "--algo-kwarg", "ppo:n_steps=64"], "keywords for ppo: expected a learned algorithm"),
        (["--policies", "ppo,lqr", "--algo-kwarg", "dqn:n_steps=64"], "--algo-kwarg 'dqn:n_steps=64': expected"),
        (["--policies", "ppo,sac,lqr", "--algo-kwarg", "n_epochs=2"], "sac keywords ['n_epochs']: not keywords of SAC"),
        (["--policies", "sac,lqr", "--trainer", "rllib"], "the RLlib trainer offers ppo only"),
        (["--policies", "lqr", "--scene", "paper-fig1"], "lqr cannot serve scene 'paper-fig1'"),
    ],
)
def test_bad_compare_input_is_a_clear_error(
    args: list[str], message: str, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["compare", "--out", str(tmp_path), "--timesteps", "64", "--no-progress", *args])
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.rglob("model.zip")) and not (tmp_path / "run.json").exists()  # stopped before training


def test_evaluate_of_a_missing_model_is_a_clear_error(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["evaluate", str(tmp_path / "nothing")])
    assert exit_info.value.code == 2
    assert "nothing" in capsys.readouterr().err


@pytest.mark.parametrize("algo", ["sac", "td3"])
def test_off_policy_algorithms_run_through_the_console_entry(algo: str, tmp_path: pathlib.Path) -> None:
    budget = ["--timesteps", "150", "--algo-kwarg", "learning_starts=50", "--algo-kwarg", "batch_size=32"]
    args = [*TINY[:TINY.index("--algo-kwarg")], *budget, "--no-progress", "--algo", algo.upper(),
            "--sweep", "start_noise=0.05"]
    assert compare_main([*args, "--out", str(tmp_path)]) == 0
    _, rows = read_csv(tmp_path / "comparison.csv")
    assert [row["policy"] for row in rows] == [f"{algo.upper()} (seed 0)", f"{algo.upper()} best (seed 0)", "LQR"]
    assert json.loads((tmp_path / "run.json").read_text())["settings"]["policies"] == [algo, "lqr"]


def test_console_scripts_point_at_the_commands() -> None:
    import tomllib  # Python >= 3.11, as set-up uses

    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["chaincart-compare"] == "chaincart_env.tools.compare.compare_cli:compare_main"
    assert scripts["chaincart"] == "chaincart_env.__main__:main"


def test_several_seeds_train_independent_agents_and_aggregate(tmp_path: pathlib.Path) -> None:
    args = [a for a in TINY if a not in ("--sweep", "start_noise=0.05,0.5")]
    assert main(["compare", *args, "--seeds", "3,4", "--sweep", "start_noise=0.1", "--out", str(tmp_path)]) == 0
    _, rows = read_csv(tmp_path / "comparison.csv")
    assert [r["policy"] for r in rows] == [
        "PPO (seed 3)", "PPO (seed 4)", "PPO best (seed 3)", "PPO best (seed 4)", "LQR",
    ]
    _, seeds = read_csv(tmp_path / "seeds.csv")
    final = next(r for r in seeds if r["policy"] == "PPO")
    per_seed = [float(r["success_rate"]) for r in rows[:2]]
    assert int(final["seeds"]) == 2 and float(final["success_mean"]) == pytest.approx(np.mean(per_seed))
    assert float(final["success_ci_low"]) <= float(final["success_mean"]) <= float(final["success_ci_high"])
    _, sweep = read_csv(tmp_path / "sweep_summary.csv")
    ppo = next(r for r in sweep if r["policy"] == "PPO")
    assert int(ppo["seeds"]) == 2 and ppo["interval"] == "bootstrap, over seeds"
    lqr = next(r for r in sweep if r["policy"] == "LQR")
    assert int(lqr["seeds"]) == 1 and lqr["interval"] == "Wilson, over episodes"
    report = (tmp_path / "report.md").read_text()
    assert "PPO (2 training seeds) against LQR" in report and "Intervals of the agent: bootstrap over seeds" in report
    assert f"PPO over 2 training seeds: success {float(final['success_mean']):.2f} [" in report
    # Different training seeds, different agents.
    a, b = (tmp_path / f"seed-{s}" / "training_episodes.csv" for s in (3, 4))
    assert a.read_text() != b.read_text()


RESUMABLE = [
    "--scene", "inverted-1", "--timesteps", "1024", "--num-envs", "2", "--eval-episodes", "3",
    "--set", "max_episode_steps=40", "--algo-kwarg", "n_steps=64", "--algo-kwarg", "batch_size=64",
    "--eval-every", "256", "--eval-starts", "2", "--checkpoint-every", "256", "--sweep", "start_noise=0.05",
    "--no-progress", "--torch-threads", "1",
]  # fmt: skip


def _interrupt_after_first_checkpoint(out: pathlib.Path, signal_number: int) -> "subprocess.CompletedProcess[str]":
    """Runs compare in a subprocess and sends it ``signal_number`` once its first
    checkpoint exists."""
    import signal as signals  # noqa: F401  (the caller passes a number from it)
    import subprocess
    import sys
    import time

    # Ctrl-C raises KeyboardInterrupt in the run even where this process ignores SIGINT
    # (a test command started in the background), which Python would otherwise inherit.
    command = ("import runpy, signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
               "sys.argv[0] = 'chaincart_env'; runpy.run_module('chaincart_env', run_name='__main__')")
    process = subprocess.Popen(
        [sys.executable, "-c", command, "compare", *RESUMABLE, "--out", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    checkpoint = out / "seed-0" / "checkpoints" / "state.json"
    deadline = time.monotonic() + 240
    while not checkpoint.is_file() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert process.poll() is None, "the run ended before its first checkpoint"
    process.send_signal(signal_number)
    stdout, stderr = process.communicate(timeout=120)
    return subprocess.CompletedProcess(process.args, process.returncode, stdout, stderr)


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    """The resumable run, uninterrupted: what every interrupted one must resume to."""
    whole = tmp_path_factory.mktemp("uninterrupted") / "whole"
    assert main(["compare", *RESUMABLE, "--out", str(whole)]) == 0
    return whole


@pytest.mark.parametrize("signal_name", ["SIGINT", "SIGTERM"])
def test_an_interrupted_run_keeps_its_files_and_resumes_to_the_uninterrupted_result(
    signal_name: str, tmp_path: pathlib.Path, uninterrupted: pathlib.Path
) -> None:
    import signal

    whole, broken = uninterrupted, tmp_path / "broken"
    finished = _interrupt_after_first_checkpoint(broken, getattr(signal, signal_name))
    assert finished.returncode != 0
    run = json.loads((broken / "run.json").read_text())
    assert run["status"] == "interrupted" and "--resume" in run["resume_with"]
    assert run["seed_runs"] == {}  # interrupted while training seed 0
    assert (broken / "config.json").is_file() and (broken / "seed-0" / "training_episodes.csv").is_file()
    assert main(["compare", "--resume", str(broken)]) == 0
    resumed = json.loads((broken / "run.json").read_text())
    assert resumed["status"] == "done" and resumed["seed_runs"]["0"]["resumed_from"] >= 256
    for name in ("comparison.csv", "episodes.csv", "sweeps.csv"):
        assert (broken / name).read_text() == (whole / name).read_text(), name
    # The logs agree but for the wall clock.
    untimed = lambda rows: [{k: v for k, v in r.items() if k != "wall_time_s"} for r in rows]  # noqa: E731
    for name in ("training_episodes.csv", "evaluations.csv"):
        resumed, uninterrupted = (read_csv(run / "seed-0" / name)[1] for run in (broken, whole))
        assert untimed(resumed) == untimed(uninterrupted) and resumed, name


def test_the_scene_recipe_sets_the_training_defaults_and_options_override_it(tmp_path: pathlib.Path) -> None:
    from chaincart_env.tools.compare.recipes import GENERIC, recipe_for

    recipe = recipe_for("inverted-2", "ppo")
    assert recipe is not GENERIC and recipe_for("paper-fig1", "PPO") is GENERIC
    base = ["--eval-episodes", "2", "--sweep", "start_noise=0.05", "--set", "max_episode_steps=20", "--no-progress",
            "--torch-threads", "1"]  # fmt: skip
    assert main(["compare", *base, "--timesteps", "64", "--out", str(tmp_path / "recipe")]) == 0
    seed_run = json.loads((tmp_path / "recipe" / "seed-0" / "run.json").read_text())
    assert seed_run["num_envs"] == recipe.num_envs
    assert seed_run["hyperparameters"] == recipe.hyperparameters
    args = [*base, "--timesteps", "64", "--num-envs", "2", "--algo-kwarg", "n_steps=32", "--algo-kwarg", "batch_size=64",
            "--out", str(tmp_path / "own")]
    assert main(["compare", *args]) == 0
    seed_run = json.loads((tmp_path / "own" / "seed-0" / "run.json").read_text())
    assert seed_run["num_envs"] == 2
    assert seed_run["hyperparameters"] == {**recipe.hyperparameters, "n_steps": 32, "batch_size": 64}


def test_a_checkpoint_swapped_in_whole_survives_an_interruption_between_its_renames(tmp_path: pathlib.Path) -> None:
    from chaincart_env.tools.compare.run_files import replace_directory, settled_directory

    final, staging, old = tmp_path / "checkpoints", tmp_path / "checkpoints.tmp", tmp_path / "checkpoints.old"
    for folder, text in ((final, "previous"), (staging, "new")):
        folder.mkdir()
        (folder / "state.json").write_text(text)
    replace_directory(staging, final)
    assert (final / "state.json").read_text() == "new" and not staging.exists() and not old.exists()
    final.rename(old)  # as if interrupted after moving the previous one aside
    assert (settled_directory(final) / "state.json").read_text() == "new" and not old.exists()
    assert settled_directory(final) == final  # nothing to do


def test_a_zoo_dict_keyword_stays_one_string_on_the_command_line() -> None:
    from chaincart_env.tools.compare.compare_cli import _algo_kwargs
    from chaincart_env.tools.compare.recipes import sb3_keywords

    shared, per_algo = _algo_kwargs(["policy_kwargs=dict(net_arch=[64, 64])", "ppo:n_steps=128,"])
    assert shared == {"policy_kwargs": "dict(net_arch=[64, 64])"}
    assert sb3_keywords(shared)["policy_kwargs"] == {"net_arch": [64, 64]}
    assert per_algo == {"ppo": {"n_steps": (128,)}}  # other values with commas are still lists


def test_the_training_log_counts_falls(tmp_path) -> None:
    from chaincart_env.tools.compare.training import train

    # An untrained agent lets the double's balance go: with a fall limit its episodes end at the fall.
    falls = ChainCartConfig(scene="inverted-2", start_noise=0.05, fall_limit=0.3)
    train(falls, timesteps=512, num_envs=4, seed=1, directory=tmp_path, eval_seeds=[1_000_000], eval_every=512,
          checkpoint_every=10_000, progress_bar=False, hyperparameters={"n_steps": 64, "batch_size": 64})
    columns, rows = read_csv(tmp_path / "training_episodes.csv")
    assert columns == list(TRAINING_EPISODE_COLUMNS) and rows
    fell = [row for row in rows if row["fell"] == "1"]
    assert fell and all(int(row["length"]) < falls.max_episode_steps for row in fell)
    assert all(row["out_of_track"] == row["numerical_failure"] == row["is_success"] == "0" for row in fell)


def test_a_resumed_training_log_keeps_the_columns_it_began_with(tmp_path) -> None:
    from chaincart_env.tools.compare.learning_curve import episode_ends, episode_log_columns, episode_row

    older = TRAINING_EPISODE_COLUMNS[:-2]  # a log begun before the fall and the plan tube had their columns
    log = tmp_path / "training_episodes.csv"
    log.write_text(",".join(older) + "\n")
    assert episode_log_columns(log) == older
    ends = episode_ends({"fell": True, "e_q": 0.7})
    assert ends == (0, 0, 0, 1, 0)
    start = [64, "0.100", 1, "3.5", 12]
    assert episode_row(older, start, ends) == [*start, 0, 0, 0]
    assert episode_row(TRAINING_EPISODE_COLUMNS, start, ends) == [*start, 0, 0, 0, 1, 0]
    assert episode_row(TRAINING_EPISODE_COLUMNS, start, episode_ends({"left_plan": True})) == [*start, 0, 0, 0, 0, 1]


def test_a_resumed_logger_appends_in_the_older_columns(tmp_path) -> None:
    from chaincart_env.tools.compare.training import EpisodeCsvLogger

    older = TRAINING_EPISODE_COLUMNS[:-2]
    log = tmp_path / "training_episodes.csv"
    log.write_text(",".join(older) + "\n" + "64,0.100,1,3.5,12,0,0,0\n")
    logger = EpisodeCsvLogger(log, append=True)
    logger._on_training_start()
    logger.num_timesteps = 128
    logger.locals = {"infos": [{"episode": {"r": 2.0, "l": 7}, "fell": True}, {}]}
    logger._on_step()
    logger._on_training_end()
    columns, rows = read_csv(log)
    assert columns == list(older) and len(rows) == 2
    assert rows[1]["episode"] == "2" and rows[1]["length"] == "7" and rows[1]["timesteps"] == "128"
    assert None not in rows[1]  # no value beyond the header's columns
