"""Optional dependencies: which extra of ``chaincart-env`` each command or class
needs, checked before any work starts so that a missing one is one clear line
(``pip install 'chaincart-env[plot]'``) instead of an ``ImportError`` halfway through."""

from __future__ import annotations

import importlib.util
from typing import Any, Iterable

from chaincart_env.errors import MissingExtraError

__all__ = ["EXTRAS", "command_needs", "require"]

#: The import names each extra provides (as in pyproject.toml).
EXTRAS: dict[str, tuple[str, ...]] = {
    "sb3": ("stable_baselines3", "torch"),
    "plot": ("matplotlib", "imageio", "imageio_ffmpeg", "tqdm", "rich", "PIL"),
    "mujoco": ("mujoco",),
}


#: Distribution names of the import names above, where they differ.
_DISTRIBUTIONS = {"stable_baselines3": "stable-baselines3", "imageio_ffmpeg": "imageio-ffmpeg", "PIL": "pillow"}


def _missing(modules: Iterable[str]) -> list[str]:
    return [m for m in modules if importlib.util.find_spec(m) is None]


def require(purpose: str, needs: dict[str, tuple[str, ...]]) -> None:
    """Raises :class:`MissingExtraError` naming the extras to install if any module
    in ``needs`` (``{extra: modules}``) is missing."""
    lacking = {extra: _missing(modules) for extra, modules in needs.items()}
    lacking = {extra: missing for extra, missing in lacking.items() if missing}
    if lacking:
        modules = ", ".join(_DISTRIBUTIONS.get(m, m) for missing in lacking.values() for m in missing)
        extras = ",".join(lacking)
        raise MissingExtraError(f"{purpose} needs {modules}, not installed: pip install 'chaincart-env[{extras}]'")


def _cluster_needs(args: Any) -> dict[str, tuple[str, ...]]:
    """A Ray cluster (``--address``) needs Ray, from the rllib extra."""
    return {"rllib": ("ray",)} if getattr(args, "address", None) is not None else {}


def command_needs(command: str, args: Any) -> dict[str, tuple[str, ...]]:
    """``{extra: modules}`` that ``python -m chaincart_env COMMAND`` with ``args`` needs."""
    if command == "compare":
        needs = {"sb3": ("stable_baselines3",), "plot": ("matplotlib", "tqdm", "rich")}
        return {**needs, **_cluster_needs(args)}
    if command == "evaluate":
        from chaincart_env.pretrained_agents import is_pretrained_slot

        # A shipped agent acts with numpy alone: no stable-baselines3, no torch.
        shipped = is_pretrained_slot(str(getattr(args, "model", "")))
        needs = {"plot": ("matplotlib",)} if shipped else {"sb3": ("stable_baselines3",), "plot": ("matplotlib",)}
        return {**needs, **_cluster_needs(args)}
    if command in ("figures", "roa"):
        return {"plot": ("matplotlib",)}
    if command == "transitions" and getattr(args, "figure", False):
        return {"plot": ("matplotlib",)}
    return {}
