"""Scene options of the command line: one ``--kebab-case`` option per
:class:`~chaincart_env.ChainCartConfig` keyword plus a generic ``--set key=value``,
turned into a validated config.

Values are read as JSON when they parse as JSON (numbers, ``true``/``false``, lists,
``{"q": 1}`` objects), as a tuple when they hold commas (``0.5,0.4``), and as a name
otherwise; ``True``/``False`` are accepted too, and ``inf`` for JSON's ``Infinity``
(``--force-rate-limit [200,inf]``). Write negative leading values with
``=`` (``--target=-1,1``) so argparse does not take them for options.
"""

from __future__ import annotations

import argparse
import json
import re
from typing import Any, Optional, Sequence

from chaincart_env import _core
from chaincart_env.config import ChainCartConfig, unknown_keyword_message
from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.config_docs import option_help

__all__ = ["CONFIG_KEYS", "add_scene_options", "config_from_options", "parse_value", "parse_assignment"]

#: Every keyword of ChainCartConfig, in the order the core defines them.
CONFIG_KEYS: tuple[str, ...] = tuple(name for name, *_ in _core.CONFIG_KEYS)


#: A bare ``inf`` or ``infinity`` (any case, signed or not), not inside a name or a string.
_INFINITY = re.compile(r'(?<![\w".])(-?)inf(?:inity)?(?![\w"])', re.IGNORECASE)


def parse_value(text: str) -> Any:
    """A command-line value as a Python value (see the module docstring)."""
    lowered = text.strip().lower()
    if lowered in ("true", "false"):
        return lowered == "true"
    try:
        value = json.loads(_INFINITY.sub(r"\1Infinity", text))
    except json.JSONDecodeError:
        if "," in text:
            return tuple(parse_value(part) for part in text.split(",") if part.strip())
        return text.strip()
    return tuple(value) if isinstance(value, list) else value


def parse_assignment(text: str) -> tuple[str, Any]:
    """``key=value`` (key with dashes or underscores) as ``(config_key, value)``."""
    key, sep, value = text.partition("=")
    key = key.strip().replace("-", "_")
    if not sep or not key:
        raise InvalidInputError(f"--set {text!r}: expected key=value, e.g. --set start_noise=0.1")
    if key not in CONFIG_KEYS:
        raise InvalidInputError(f"--set {text!r}: {unknown_keyword_message(key)}")
    return key, parse_value(value)


def add_scene_options(parser: argparse.ArgumentParser) -> None:
    """Adds ``--scene``, ``--n-links``, ... (every config keyword) and ``--set``."""
    group = parser.add_argument_group("scene (any ChainCartConfig keyword; unset ones take the scene's value)")
    for key in CONFIG_KEYS:
        group.add_argument(
            "--" + key.replace("_", "-"), dest=f"config_{key}", default=None, metavar="VALUE", help=option_help(key)
        )
    group.add_argument(
        "--set",
        dest="config_assignments",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="any config keyword (repeatable), e.g. --set n_links=3",
    )


def config_overrides(args: argparse.Namespace) -> dict[str, Any]:
    """The config keywords given on the command line (``--set`` last, so it wins)."""
    overrides: dict[str, Any] = {}
    for key in CONFIG_KEYS:
        text: Optional[str] = getattr(args, f"config_{key}", None)
        if text is not None:
            overrides[key] = text if key == "scene" else parse_value(text)
    assignments: Sequence[str] = getattr(args, "config_assignments", [])
    for text in assignments:
        key, value = parse_assignment(text)
        overrides[key] = value
    return overrides


def config_from_options(args: argparse.Namespace) -> ChainCartConfig:
    """The validated config of the command line (raises ChainCartError on bad values)."""
    return ChainCartConfig(**config_overrides(args))
