"""Help texts of the command line: docstrings as plain text, and the ``--scene``
option's help with the names of the scenes."""

from __future__ import annotations

import re

from chaincart_env import _core

__all__ = ["plain", "scene_help"]

_LITERAL = re.compile(r"``(.+?)``", re.DOTALL)
_ROLE = re.compile(r":[a-z]+:`~?(?:[\w.]+\.)?(\w+)`")


def plain(text: str) -> str:
    """``text`` (a reStructuredText docstring) with its inline markup removed:
    ``code`` and :class:`~a.Name` read as code and Name."""
    return _ROLE.sub(r"\1", _LITERAL.sub(r"\1", text))


def scene_help(default: str = _core.DEFAULT_SCENE) -> str:
    """The help of a ``--scene`` option: the scene names and what the default is."""
    return f"scene name: {', '.join(_core.SCENES)} (default: {default})"
