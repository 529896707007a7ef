"""The command line explains itself: every option of every command has a help text,
help texts are plain text (no reStructuredText markup), every ``--scene`` option lists
the scene names, and ``docs --check`` says what it checked."""

from __future__ import annotations

import argparse

import pytest

from chaincart_env import _core
from chaincart_env.__main__ import build_parser, main, subcommand_parsers

PARSER = build_parser()
COMMANDS = subcommand_parsers(PARSER)


def help_of(parser: argparse.ArgumentParser) -> str:
    return parser.format_help()


def test_every_command_is_covered() -> None:
    assert {"demo", "bench", "soak", "figures", "roa", "compare", "evaluate", "animate", "docs"} <= set(COMMANDS)


@pytest.mark.parametrize("name", ["(top level)", *COMMANDS])
def test_help_is_plain_text(name: str) -> None:
    text = help_of(PARSER if name == "(top level)" else COMMANDS[name])
    assert "``" not in text and ":class:" not in text and ":func:" not in text, text


@pytest.mark.parametrize("name", list(COMMANDS))
def test_every_option_has_a_help_text(name: str) -> None:
    undocumented = [
        action.option_strings or [action.dest]
        for action in COMMANDS[name]._actions
        if not isinstance(action, argparse._HelpAction) and not (action.help or "").strip()
    ]
    assert undocumented == []


def test_demo_explains_its_policy_and_seed() -> None:
    text = " ".join(help_of(COMMANDS["demo"]).split())
    assert "lqr: the paper's LQR" in text and "zero: no force" in text and "random: uniform actions" in text
    assert "--seed SEED reset seed of the episode" in text


@pytest.mark.parametrize("name", [name for name, parser in COMMANDS.items() if "--scene" in parser._option_string_actions])
def test_every_scene_option_lists_the_scene_names(name: str) -> None:
    action = COMMANDS[name]._option_string_actions["--scene"]
    listed = (action.help or "").replace("%%", "%")
    assert all(scene in listed for scene in _core.SCENES), listed
    assert _core.DEFAULT_SCENE in listed.partition("default")[2]


def test_docs_check_says_what_it_checked_and_that_it_is_current(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["docs", "--check"]) == 0
    out = capsys.readouterr().out
    assert "docs/configuration.md (config-keys, scenes)" in out and "docs/sim-to-real.md (reality-keys)" in out
    assert out.strip().endswith("all 2 pages are current")
