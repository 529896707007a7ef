"""The product's pages (README.md, ARCHITECTURE.md, docs/*.md) describe the software: a
measurement states its date, machine and load, never who or what else was using the
machine (other developers or engineers, their builds, training runs beside it, "this
VM")."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", ROOT / "ARCHITECTURE.md", *sorted((ROOT / "docs").glob("*.md"))]

#: Phrases that describe other users of the machine rather than the product or a load
#: figure. Matched case-insensitively, within one line or across a line break.
MACHINE_LOG = [
    r"\bother\s+(developers|engineers|users|people|teams?)\b",
    r"\b(developers|engineers|colleagues)'",
    r"\bthis\s+VM\b",
    r"\bshared\s+(\d+-core\s+)?(VM|machine|host|cores?|CPUs?)\b",
    r"\b\d+\s+shared\s+(cores?|CPUs?)\b",
    r"\bother\s+(builds|jobs|training\s+runs?)\s+(ran|running|were\s+running|beside|on\s+it)\b",
    r"\b(shared|busy)\s+with\s+other\b",
    r"\bwhile\s+(\w+\s+)?other\s+(developers|engineers|builds|jobs|training)\b",
    r"\bwith\s+other\s+(builds|jobs|training\s+runs?)\b",
    r"\btraining\s+(runs?|jobs?)\s+(beside|pinned|busy|on\s+the\s+other\s+core|running)\b",
    r"\bbeside\s+(one|two|three|four|a|an|other)\s+(other\s+)?(training\s+)?(runs?|jobs?|builds?)\b",
    r"\b(runs?|jobs?|builds?)\s+beside\s+(it|them)\b",
    r"\bbeside\s+the\s+test\s+suite\b",
    r"\b(test\s+suite|tests?)\s+(was\s+|were\s+)?running\s+beside\b",
    r"\bbuil(t|ding)\s+(Rust\s+)?on\s+it\b",
]
_PATTERNS = [re.compile(p, re.IGNORECASE) for p in MACHINE_LOG]


def machine_log_phrases(text: str) -> list[str]:
    """Each phrase of ``text`` that describes other users of the machine, with its line
    number (a phrase broken across two lines counts on the line it starts)."""
    found = []
    lines = text.splitlines()
    for number, line in enumerate(lines, start=1):
        joined = line + " " + (lines[number] if number < len(lines) else "")
        for pattern in _PATTERNS:
            match = pattern.search(joined)
            if match and match.start() < len(line):
                found.append(f"line {number}: {match.group(0)!r}")
    return found


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_the_page_names_no_other_users_of_the_machine(page: Path) -> None:
    assert machine_log_phrases(page.read_text()) == []


@pytest.mark.parametrize(
    "line",
    [
        "while four other developers built Rust on it (load average 9 to 13)",
        "x86_64, 2 logical CPUs shared with four other engineers building and testing",
        "AMD EPYC, a Zen 4 core), shared with other engineers' builds,",
        "on this VM with nothing else heavy running",
        "the shared 2-core VM with two training runs beside it, 2026-11-25",
        "a training job on the other core, 1-min load average 1.9",
        "Measured here (2 shared cores, other jobs running):",
        "31 minutes on this machine beside the test suite",
        "on the project's 2-core x86-64 VM **while other builds and tests ran** (load",
        "on the shared\n2-core VM, load 2",
        "load average 2.1 at the start (the test suite\nwas running beside them)",
    ],
)
def test_the_check_finds_a_planted_line(line: str) -> None:
    page = f"# A page\n\nThe env steps fast.\n{line}\nMore text.\n"
    found = machine_log_phrases(page)
    assert found and found[0].startswith("line 4:"), found


@pytest.mark.parametrize(
    "line",
    [
        "Measured 2026-11-25 on a 2-core x86_64 machine (1-minute load average 9-17).",
        "with MuJoCo beside it, is in the performance page",
        "`compare` keeps the best evaluated model beside the final `model.zip`",
        "the fastest for these small networks on a loaded machine",
        "runners wait for CPUs that other jobs hold",
        "a bad action is rejected while other envs carry on",
        "## Other processes: the module-qualified id",
    ],
)
def test_the_check_lets_product_text_through(line: str) -> None:
    assert machine_log_phrases(f"# A page\n\n{line}\n") == []
