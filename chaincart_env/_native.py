"""Loading the native module ``chaincart_env._core`` with a hint when it is missing."""

from __future__ import annotations

import importlib
from pathlib import Path
from types import ModuleType

__all__ = ["load_native_module"]


def load_native_module() -> ModuleType:
    """``chaincart_env._core``; where it is not built, a ``ModuleNotFoundError`` that
    says how to build it (in a source checkout) or to reinstall (elsewhere).

    numpy is imported first: the native module's initialisation imports Python code
    that needs it, and would raise that code's ImportError; this one says what to
    install."""
    try:
        importlib.import_module("numpy")
    except ImportError as error:
        raise ModuleNotFoundError(
            f"chaincart_env needs numpy, a required dependency, and it cannot be imported ({error}): install it "
            "with `pip install numpy`, or reinstall with `pip install --force-reinstall chaincart-env`",
            name="numpy",
        ) from error
    try:
        return importlib.import_module("chaincart_env._core")
    except ModuleNotFoundError as error:
        if error.name != "chaincart_env._core":
            raise
        package = Path(__file__).resolve().parent
        if (package.parent / "Cargo.toml").is_file():
            hint = (
                f"chaincart_env is imported from the source checkout {package.parent} whose native module "
                "chaincart_env._core is not built: build it there with `maturin develop --release` (or "
                "scripts/setup.sh), or run from another directory to use an installed chaincart-env"
            )
        else:
            hint = (
                f"the native module chaincart_env._core is missing from {package}: reinstall with "
                "`pip install --force-reinstall chaincart-env`"
            )
        raise ModuleNotFoundError(hint, name=error.name) from error
