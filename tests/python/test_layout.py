"""The package's layout: the library (envs, model, policies, rendering) apart from the
command-line tools (``chaincart_env.tools``), and no import circles. Read from the
installed package's own source, so it holds for a wheel as for a checkout."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import chaincart_env

PACKAGE = Path(chaincart_env.__file__).resolve().parent

#: Library modules allowed to reach the tools, and why: the command line is the tools'
#: entry point.
TOOL_USERS = {"chaincart_env.__main__"}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in PACKAGE.rglob("*.py")}


def _absolute(node: ast.ImportFrom, path: Path) -> str:
    """The module ``from ... import`` names, relative ones (``from . import x``, ``from
    ..y import z``) resolved against the package ``path`` is in."""
    if node.level == 0:
        return node.module or ""
    package = _module_name(path).split(".")
    if path.name != "__init__.py":
        package.pop()  # a module's own package; a package's __init__ is that package
    package = package[: len(package) - (node.level - 1)]
    return ".".join(package + ([node.module] if node.module else []))


def _imports(path: Path, modules: dict[str, Path], source: str | None = None) -> set[str]:
    """The package's modules that ``path`` (or ``source`` read as if it were ``path``)
    imports, at the top or inside functions, absolutely or relatively; ``from package
    import name`` counts the submodule ``package.name`` where there is one, else the
    package."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text() if source is None else source)):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            module = _absolute(node, path)
            names = [module] + [f"{module}.{a.name}" for a in node.names]
        else:
            continue
        for name in names:
            while name and name not in modules:
                name = name.rpartition(".")[0]
            if name.startswith("chaincart_env"):
                found.add(name)
    return found


def test_imports_are_read_absolute_and_relative() -> None:
    # Source read as if it were a module chaincart_env/policies/_sample.py.
    modules = _modules()
    sample = PACKAGE / "policies" / "_sample.py"
    text = (
        "import chaincart_env.model\n"
        "from . import mpc\n"
        "from . import lqr\n"
        "from .. import errors\n"
        "from ..tools.roa_cli import run_roa\n"
        "from ..rendering import camera\n"
        "def f():\n    from .settings import EnvSettings\n"
    )
    assert _imports(sample, modules, text) == {
        "chaincart_env.model",
        "chaincart_env.policies.mpc",
        "chaincart_env.policies.lqr",
        "chaincart_env.errors",
        "chaincart_env.tools.roa_cli",
        "chaincart_env.rendering.camera",
        "chaincart_env.policies.settings",
        "chaincart_env.policies",
        "chaincart_env",
        "chaincart_env.rendering",
    }
    init = PACKAGE / "policies" / "__init__.py"
    assert _absolute(ast.parse("from . import mpc").body[0], init) == "chaincart_env.policies"  # type: ignore[arg-type]
    assert _absolute(ast.parse("from .. import lqr").body[0], init) == "chaincart_env"  # type: ignore[arg-type]


def test_import_chaincart_env_loads_no_tool(tmp_path: Path) -> None:
    code = (
        "import sys, chaincart_env\n"
        "print('\\n'.join(m for m in sys.modules if m.startswith('chaincart_env.tools')"
        " or m.split('.')[0] in ('matplotlib', 'stable_baselines3', 'torch', 'ray', 'mujoco')))"
    )
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path)
    assert loaded.stdout.strip() == "", loaded.stdout


def test_the_library_does_not_import_the_tools() -> None:
    modules = _modules()
    assert "chaincart_env.tools.bench.suite" in modules and "chaincart_env.env" in modules
    wrong = {
        name: sorted(m for m in _imports(path, modules) if m.startswith("chaincart_env.tools"))
        for name, path in modules.items()
        if not name.startswith("chaincart_env.tools") and name not in TOOL_USERS
    }
    assert {k: v for k, v in wrong.items() if v} == {}


def test_modules_import_each_other_without_circles() -> None:
    modules = _modules()
    graph = {
        name: {m for m in _imports(path, modules) if m != name and not name.startswith(m + ".")}
        for name, path in modules.items()
    }
    # Remove modules that import no remaining module until none is left (or a circle is).
    left = set(graph)
    while True:
        leaves = {m for m in left if not (graph[m] & left)}
        if not leaves:
            break
        left -= leaves
    assert left == set(), f"modules in a circle: {sorted(left)}"


def _undocumented(path: Path) -> list[str]:
    """The public functions, methods and classes of ``path`` (properties included) that
    have no docstring; a property's setter or deleter shares its getter's."""
    missing: list[str] = []

    def walk(body: list[ast.stmt], prefix: str) -> None:
        for node in body:
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                continue
            if node.name.startswith("_"):
                continue
            accessor = any(
                isinstance(d, ast.Attribute) and d.attr in ("setter", "deleter") for d in node.decorator_list
            )
            if not accessor and ast.get_docstring(node) is None:
                missing.append(f"{prefix}{node.name} (line {node.lineno})")
            if isinstance(node, ast.ClassDef):
                walk(node.body, f"{prefix}{node.name}.")

    walk(ast.parse(path.read_text()).body, "")
    return missing


def test_public_functions_methods_and_classes_have_docstrings() -> None:
    missing = {name: found for name, path in sorted(_modules().items()) if (found := _undocumented(path))}
    assert missing == {}


def test_the_docstring_check_finds_what_it_must(tmp_path: Path) -> None:
    source = tmp_path / "sample.py"
    source.write_text(
        'class A:\n    """A."""\n\n    @property\n    def p(self):\n        return 1\n\n'
        "    @p.setter\n    def p(self, v):\n        pass\n\n    def _private(self):\n        pass\n\n"
        'def f():\n    """F."""\n\n    def inner():\n        pass\n\n'
        "class B:\n    pass\n"
    )
    assert [m.split(" ")[0] for m in _undocumented(source)] == ["A.p", "B"]
