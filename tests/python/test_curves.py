"""``curves``: learning curves of compare studies over seeds, read from their files, with
the page's numbers checked on hand-made studies."""

from __future__ import annotations

import csv
import json
import pathlib

import numpy as np
import pytest

from chaincart_env.__main__ import main
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.curves import first_reaching, read_study_curves, steady, write_curves

COLUMNS = ("timesteps", "wall_time_s", "episodes", "success_rate", "ci_low", "ci_high", "return_mean", "return_std")


def _study(folder: pathlib.Path, successes: dict[int, list[float]], policies=("ppo",)) -> pathlib.Path:
    """A compare study whose seeds were evaluated every 100 steps with these successes."""
    folder.mkdir(parents=True)
    seeds = sorted(successes)
    (folder / "run.json").write_text(json.dumps({"settings": {"policies": list(policies), "seeds": seeds}}))
    learned = [p for p in policies if p != "lqr"]
    for algo in learned:
        for seed in seeds:
            directory = folder / (f"{algo}/seed-{seed}" if len(learned) > 1 else f"seed-{seed}")
            directory.mkdir(parents=True)
            with (directory / "evaluations.csv").open("w", newline="") as file:
                writer = csv.writer(file)
                writer.writerow(COLUMNS)
                for k, success in enumerate(successes[seed]):
                    writer.writerow((100 * k, 10.0 * k + seed, 20, success, 0, 1, 100 * success, 1))
    return folder


def test_the_page_times_the_goal_per_seed_and_over_seeds(tmp_path: pathlib.Path):
    study = _study(tmp_path / "recipe", {
        0: [0, 0.5, 0.95, 1, 1, 1, 1, 1],
        1: [0, 0, 0, 0.9, 0.8, 1, 1, 1],
        2: [0, 0, 0, 0, 0, 0, 0, 0],
    })
    assert main(["curves", f"mine={study}", "--out", str(tmp_path / "out"), "--note", "Runs of the test."]) == 0
    page = (tmp_path / "out" / "learning-curves.md").read_text()
    assert "\n\nRuns of the test.\n\n" in page and f"curves mine={study} --out" in page
    # Mean success reaches 0.9 never (seed 2 holds it at 2/3 at most); seed 0 at step 200, steady;
    # seed 1 at step 300 but not steady (0.8 among its last five).
    assert "| mine | 3 | never | 0: 200 steady, 1: 300, 2: never |" in page
    assert (tmp_path / "out" / "learning-curves.png").stat().st_size > 10_000
    recipe = read_study_curves(study)[0]
    assert recipe.label == "recipe" and recipe.seeds == (0, 1, 2) and recipe.success.shape == (3, 8)
    assert first_reaching(recipe.steps, recipe.success[0], 0.9) == 200.0
    assert first_reaching(recipe.steps, recipe.success[1], 0.9) == 300.0
    assert steady(recipe.success[0], 0.9) and not steady(recipe.success[1], 0.9)
    assert np.array_equal(recipe.wall_time_s[:, 1], [10.0, 11.0, 12.0])


def test_a_study_of_two_algorithms_is_two_recipes_cut_to_their_common_evaluations(tmp_path: pathlib.Path):
    study = _study(tmp_path / "both", {0: [0, 1, 1], 1: [0, 1, 1]}, policies=("ppo", "ppo-robust", "lqr"))
    rows = (study / "ppo-robust" / "seed-1" / "evaluations.csv").read_text().splitlines()
    (study / "ppo-robust" / "seed-1" / "evaluations.csv").write_text("\n".join(rows[:-1]) + "\n")  # one fewer
    recipes = read_study_curves(study, "x")
    assert [r.label for r in recipes] == ["x PPO", "x PPO robust"]
    assert recipes[0].steps.tolist() == [0, 100, 200] and recipes[1].steps.tolist() == [0, 100]


def test_bad_studies_are_refused_by_name(tmp_path: pathlib.Path):
    with pytest.raises(InvalidInputError, match=r"nowhere: no run.json and no seed-<s>/ folders"):
        write_curves([(None, tmp_path / "nowhere")], tmp_path / "out")
    study = _study(tmp_path / "a", {0: [0, 1]})
    with pytest.raises(InvalidInputError, match=r"recipes labelled \['same'\] more than once"):
        write_curves([("same", study), ("same", study)], tmp_path / "out")
    with pytest.raises(InvalidInputError, match=r"goal = 1.5: expected a success rate in \(0, 1\]"):
        write_curves([(None, study)], tmp_path / "out", goal=1.5)
    (study / "seed-0" / "evaluations.csv").unlink()
    with pytest.raises(InvalidInputError, match=r"evaluations.csv: no such file"):
        read_study_curves(study)


def test_a_leaderboard_agents_folder_is_one_recipe(tmp_path: pathlib.Path):
    study = _study(tmp_path / "ppo-robust", {0: [0, 1, 1], 2: [0, 0.5, 1]})
    (study / "run.json").unlink()  # as a leaderboard's agents/<scene>/<controller>/
    (study / "seed-x").mkdir()  # not a seed
    recipe = read_study_curves(study)[0]
    assert recipe.label == "ppo-robust" and recipe.seeds == (0, 2) and recipe.success.tolist() == [[0, 1, 1], [0, 0.5, 1]]


def test_a_polished_run_is_one_curve_from_its_first_stage_on(tmp_path: pathlib.Path):
    study = _study(tmp_path / "polished", {0: [1, 1, 0.95]})  # the polish: step 0 re-scores the first stage's best
    stage = study / "seed-0" / "main-stage"
    stage.mkdir()
    with (stage / "evaluations.csv").open("w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(COLUMNS)
        for k, success in enumerate([0, 0.5, 1, 1]):
            writer.writerow((1000 * k, 7.0 * k, 20, success, 0, 1, 100 * success, 1))
    with (stage / "training_episodes.csv").open("w", newline="") as file:  # the first stage went on past 3000
        file.write("timesteps,wall_time_s,episode,return,length,is_success,out_of_track,numerical_failure\n"
                   "2990,20.5,1,1.0,300,1,0,0\n3100,22.0,2,1.0,300,1,0,0\n")
    recipe = read_study_curves(study)[0]
    assert recipe.steps.tolist() == [0, 1000, 2000, 3000, 3100, 3200, 3300]
    assert recipe.success[0].tolist() == [0, 0.5, 1, 1, 1, 1, 0.95]
    assert recipe.wall_time_s[0].tolist() == [0, 7, 14, 21, 22, 32, 42]
    assert first_reaching(recipe.steps, recipe.success[0], 0.9) == 2000.0 and steady(recipe.success[0], 0.9)
