"""Every Python block of README.md and docs/*.md runs, and the outputs it documents
(``#>`` lines after a ``print``) are what it prints."""

from __future__ import annotations

from pathlib import Path

import pytest
from pytest_examples import CodeExample, EvalExample

from docs_examples import examples_of, run_example

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
EXAMPLES = examples_of(*PAGES)


def test_the_docs_have_python_examples() -> None:
    pages = {Path(ex.path).name for ex in EXAMPLES}
    assert {"README.md", "control.md", "rendering.md"} <= pages


@pytest.mark.parametrize("example", EXAMPLES, ids=str)
def test_python_block_runs_and_prints_what_it_documents(
    example: CodeExample, eval_example: EvalExample, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)  # blocks that write files write them here
    run_example(example, eval_example)


def test_the_readme_states_the_steps_the_main_job_trains() -> None:
    # SB3 trains whole rollouts: the default scene's budget rounded up to num_envs x n_steps.
    from chaincart_env.tools.compare.recipes import recipe_for
    from chaincart_env.config import DEFAULT_SCENE

    recipe = recipe_for(DEFAULT_SCENE, "ppo")
    rollout = recipe.num_envs * recipe.hyperparameters["n_steps"]
    trained = -(-recipe.timesteps // rollout) * rollout
    assert f"# the main job trains {trained:,} steps" in (ROOT / "README.md").read_text()
