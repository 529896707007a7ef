"""Text generated from the core's one definition of the configuration (its keys and
scenes): the two tables of ``docs/configuration.md`` and the command line's option
help. (The argument list of the :class:`~chaincart_env.ChainCartEnv` docstring is
:func:`chaincart_env.config.env_arguments`, part of the library.)

``python -m chaincart_env docs --write`` rewrites the generated parts of the docs
(between ``<!-- generated: NAME -->`` and ``<!-- end generated: NAME -->``);
``--check`` exits with status 1 when a committed page differs from the definition.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from chaincart_env import _core
from chaincart_env.config import value_text

__all__ = ["keys_table", "scenes_table", "option_help", "generated_pages", "main"]

_DOCS = Path(__file__).resolve().parents[2] / "docs"


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def keys_table(only: tuple[str, ...] = ()) -> str:
    """The configuration keys (``only`` these, if given) as a Markdown table: keyword,
    meaning, accepted values, default (the default scene's value)."""
    rows = [
        "| keyword | meaning | accepts | default |",
        "|---|---|---|---|",
    ]
    for name, default, help_text, expected in _core.CONFIG_KEYS:
        if only and name not in only:
            continue
        rows.append(f"| `{name}` | {_cell(help_text)} | {_cell(expected)} | `{value_text(default)}` |")
    return "\n".join(rows)


def _scene_changes(scene: str) -> dict[str, Any]:
    """The values of ``scene`` that differ from the key defaults."""
    defaults = {name: default for name, default, _, _ in _core.CONFIG_KEYS}
    values = _core.SCENES[scene]
    return {k: v for k, v in values.items() if k != "scene" and v != defaults[k]}


def scenes_table() -> str:
    """The scenes as a Markdown table: name, what it is, its values that differ from
    the defaults."""
    rows = ["| scene | what | values (others: the defaults) |", "|---|---|---|"]
    for scene, summary in _core.SCENE_SUMMARIES.items():
        changes = ", ".join(f"`{k}={value_text(v)}`" for k, v in _scene_changes(scene).items())
        shown = f"`{scene}` (default)" if scene == _core.DEFAULT_SCENE else f"`{scene}`"
        rows.append(f"| {shown} | {_cell(summary)} | {_cell(changes) or '(the defaults)'} |")
    return "\n".join(rows)


def option_help(name: str) -> str:
    """The command line's help of the option of configuration key ``name``."""
    for key, default, help_text, _ in _core.CONFIG_KEYS:
        if key == name:
            if key == "scene":
                help_text = f"{help_text}: {', '.join(_core.SCENES)}"
            return f"{help_text} (default scene: {value_text(default)})".replace("%", "%%")
    raise KeyError(name)


#: Generated parts of the docs: (page, name) -> generator.
_SECTIONS: dict[tuple[str, str], Callable[[], str]] = {
    ("configuration.md", "config-keys"): keys_table,
    ("configuration.md", "scenes"): scenes_table,
    ("sim-to-real.md", "reality-keys"): lambda: keys_table(tuple(name for name, _, _ in _core.REALITY_KEYS)),
}


def _with_section(text: str, name: str, content: str) -> str:
    begin, end = f"<!-- generated: {name} -->", f"<!-- end generated: {name} -->"
    head, found, rest = text.partition(begin)
    if not found or end not in rest:
        raise ValueError(f"markers {begin!r} ... {end!r} not found")
    return f"{head}{begin}\n{content}\n{end}{rest.partition(end)[2]}"


def generated_pages(docs: Path = _DOCS) -> dict[Path, tuple[str, str]]:
    """Each page with generated parts: ``(committed text, text with the parts regenerated)``."""
    pages: dict[Path, tuple[str, str]] = {}
    for (page, name), generate in _SECTIONS.items():
        path = docs / page
        committed, current = pages.get(path, (path.read_text(), path.read_text()))
        pages[path] = (committed, _with_section(current, name, generate()))
    return pages


def add_docs_command(commands: Any) -> None:
    """Adds ``docs`` (``--write`` / ``--check``) to the command line."""
    parser = commands.add_parser("docs", help="regenerate (--write) or check (--check) the configuration tables")
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", action="store_true", help="rewrite the generated parts of the docs")
    mode.add_argument("--check", action="store_true", help="exit 1 if a page differs from the definition")
    parser.set_defaults(handler=lambda args, _parser: main(write=args.write))


def _checked_parts() -> str:
    """The generated parts, page by page: ``configuration.md (config-keys, scenes), ...``."""
    names: dict[str, list[str]] = {}
    for page, name in _SECTIONS:
        names.setdefault(page, []).append(name)
    return ", ".join(f"docs/{page} ({', '.join(parts)})" for page, parts in names.items())


def main(write: bool) -> int:
    """Writes or checks the generated parts, saying what it checked or rewrote; 1 when
    ``--check`` finds a stale page."""
    pages = generated_pages()
    stale = {path: new for path, (old, new) in pages.items() if old != new}
    print(f"generated from the core's configuration (keys and scenes): {_checked_parts()}")
    if write:
        for path, new in stale.items():
            path.write_text(new)
            print(f"rewrote docs/{path.name}")
        if not stale:
            print("nothing to rewrite: every page is current")
        return 0
    for path in stale:
        print(f"docs/{path.name} differs from the configuration the core defines: run python -m chaincart_env docs --write")
    if not stale:
        print(f"all {len(pages)} pages are current")
    return 1 if stale else 0

