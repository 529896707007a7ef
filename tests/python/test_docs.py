"""Every Python block of README.md and docs/*.md runs, and the outputs it documents
(``#>`` lines after a ``print``) are what it prints."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest
from docs_examples import examples_of, run_example
from pytest_examples import CodeExample, EvalExample

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
EXAMPLES = examples_of(*PAGES)


def test_the_docs_have_python_examples() -> None:
    pages = {Path(ex.path).name for ex in EXAMPLES}
    assert {"README.md", "control.md", "rendering.md"} <= pages


@pytest.mark.parametrize("example", EXAMPLES, ids=str)
def test_python_block_runs_and_prints_what_it_documents(
    example: CodeExample, eval_example: EvalExample, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    request: pytest.FixtureRequest,
) -> None:
    monkeypatch.chdir(tmp_path)  # blocks that write files write them here
    if "ray.init(" in example.source:
        # Beside another user's Ray cluster, named by RAY_ADDRESS: the block starts its own.
        monkeypatch.setenv("RAY_ADDRESS", request.getfixturevalue("foreign_ray_cluster"))
    run_example(example, eval_example)


def test_the_readme_states_the_steps_the_main_job_trains() -> None:
    # SB3 trains whole rollouts: the default scene's budget rounded up to num_envs x n_steps.
    from chaincart_env.config import DEFAULT_SCENE
    from chaincart_env.tools.compare.recipes import recipe_for

    recipe = recipe_for(DEFAULT_SCENE, "ppo")
    rollout = recipe.num_envs * recipe.hyperparameters["n_steps"]
    trained = -(-recipe.timesteps // rollout) * rollout
    assert f"# the main job trains {trained:,} steps" in (ROOT / "README.md").read_text()


# The maps of the tree (ARCHITECTURE.md, README's "Repository layout") against the tree.

PACKAGE = ROOT / "chaincart_env"
_CODE = re.compile(r"`([^`\n]+)`")


def _section(page: Path, heading: str) -> str:
    """The text of ``page`` from the heading ``heading`` to the next heading of its level."""
    text = page.read_text()
    level = heading.split(" ")[0]
    start = text.index(heading + "\n")
    end = text.find("\n" + level + " ", start + len(heading))
    return text[start : end if end >= 0 else len(text)]


def _row(text: str, first_cell: str) -> str:
    """The table row of ``text`` whose first cell is ``first_cell``."""
    return next(line for line in text.splitlines() if line.startswith(f"| {first_cell} |"))


def _src_modules() -> set[str]:
    return {p.stem for p in (ROOT / "src").iterdir() if p.is_dir() or (p.suffix == ".rs" and p.stem != "lib")}


def _package_entries(folder: Path) -> set[str]:
    """The modules of ``folder`` as a map names them (``x.py``, ``x.pyi``, ``x/``), without
    ``__init__.py`` and caches."""
    entries = set()
    for p in folder.iterdir():
        if p.is_dir() and p.name != "__pycache__":
            entries.add(p.name + "/")
        elif p.suffix in (".py", ".pyi") and p.name != "__init__.py":
            entries.add(p.name)
    return entries


#: File names the maps use for a kind of file, not one path.
_KINDS = {"mod.rs"}


def _paths_named(text: str) -> set[str]:
    """The code spans of ``text`` that name a file or folder (a ``/`` or a file suffix)."""
    return {
        span
        for span in _CODE.findall(text)
        if " " not in span
        and "<" not in span
        and span not in _KINDS
        and ("/" in span or re.search(r"\.(py|pyi|rs|md|toml|yml)$", span))
    }


def _exists(path: str) -> bool:
    """Whether ``path`` is a file or folder of the repository, of ``src/`` or of the package."""
    return any((base / path).exists() for base in (ROOT, ROOT / "src", PACKAGE, PACKAGE / "tools"))


def test_architecture_names_every_module_of_the_tree() -> None:
    page = ROOT / "ARCHITECTURE.md"
    core = set(_CODE.findall(_section(page, "## The Rust core: a ladder")))
    python = _section(page, "## The Python package")
    named = set(_CODE.findall(python))
    tools = set(_CODE.findall(_row(python, "`tools/`")))
    assert _src_modules() - core == set(), "src/ modules ARCHITECTURE.md does not place"
    assert _package_entries(PACKAGE) - named == set(), "package modules ARCHITECTURE.md does not name"
    tool_modules = {e.removesuffix(".py").removesuffix("/") for e in _package_entries(PACKAGE / "tools")}
    assert tool_modules - tools == set(), "tools ARCHITECTURE.md does not name"


def _tracked_top_level_folders() -> set[str]:
    """The repository's top-level folders that git tracks files in (``src/``, ...)."""
    files = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return {path.split("/")[0] + "/" for path in files.splitlines() if "/" in path}


def test_the_readme_layout_names_every_top_level_folder_and_points_to_the_map() -> None:
    layout = _section(ROOT / "README.md", "## Repository layout")
    folders = _tracked_top_level_folders()
    assert {"src/", "chaincart_env/", "docs/", "tests/"} <= folders
    named = {span.split("/")[0] + "/" for span in _CODE.findall(layout) if "/" in span}
    assert folders - named == set(), "top-level folders the README layout does not name"
    assert "[ARCHITECTURE.md](ARCHITECTURE.md)" in layout


def test_the_ladder_is_written_only_in_architecture() -> None:
    # The README points to ARCHITECTURE.md for the core's modules instead of listing them.
    readme_spans = set(_CODE.findall((ROOT / "README.md").read_text()))
    assert sorted(_src_modules() & readme_spans) == []


@pytest.mark.parametrize("page, heading", [("ARCHITECTURE.md", "# Architecture"), ("README.md", "## Repository layout")])
def test_every_path_the_maps_name_exists(page: str, heading: str) -> None:
    text = _section(ROOT / page, heading)
    paths = _paths_named(text)
    assert len(paths) >= 5, paths
    assert sorted(p for p in paths if not _exists(p)) == []


def test_every_module_the_maps_name_exists() -> None:
    architecture = ROOT / "ARCHITECTURE.md"
    ladder = [line for line in _section(architecture, "## The Rust core: a ladder").splitlines() if line.startswith("| ")]
    rust = {span for line in ladder[2:] for span in _CODE.findall(line.split("|")[2])}
    assert "model" in rust and rust - _src_modules() == set()
    tools_row = _row(_section(architecture, "## The Python package"), "`tools/`").split("|")[2]
    tools = {span for span in _CODE.findall(tools_row) if span.isidentifier()}
    assert "bench" in tools
    assert sorted(t for t in tools if not _exists(t) and not _exists(t + ".py")) == []


# The performance page: generated by the bench command, which keeps its hand-written sections.


def test_writing_the_performance_page_again_keeps_its_hand_written_sections() -> None:
    from chaincart_env.tools.bench.suite import HAND_WRITTEN, hand_written_sections, performance_page

    page = (ROOT / "docs" / "performance.md").read_text()
    kept = hand_written_sections(page)
    headings = [line for line in kept.splitlines() if line.startswith("## ")]
    assert f"## Set-up and the two commands {HAND_WRITTEN}" in headings
    assert len(headings) >= 3 and all(h.endswith(HAND_WRITTEN) for h in headings)
    assert "## Speed targets" in page and "## Speed targets" not in kept  # generated: not kept
    report = "# chaincart benchmark\n\nmachine line\n\n## Speed targets\n\n| a |\n|---|\n| 1 |\n"
    written = performance_page(report, "python -m chaincart_env bench", kept)
    assert written.startswith("# Performance\n") and "\n## Speed targets\n" in written
    assert written.index("## Speed targets") < written.index(headings[0])
    assert hand_written_sections(written) == kept  # kept again by the next run, unchanged


def test_a_heading_inside_a_code_block_does_not_start_or_end_a_kept_section() -> None:
    from chaincart_env.tools.bench.suite import HAND_WRITTEN, hand_written_sections

    page = f"# Performance\n\n## Generated\n\nx\n\n## Notes {HAND_WRITTEN}\n\n```bash\n## not a heading\n```\n\ny\n\n## Generated too\n\nz\n"
    assert hand_written_sections(page) == f"## Notes {HAND_WRITTEN}\n\n```bash\n## not a heading\n```\n\ny"
