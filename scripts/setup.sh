#!/usr/bin/env bash
# Set-up of a machine that has only Rust and Python 3.11 with pip (idempotent).
#
# Installs Xvfb (and Tk for matplotlib's window) with apt-get when missing on a Debian
# machine where it runs as root: the human-mode window tests need a display server.
# Creates .venv, installs maturin, then builds the Rust extension in release mode and
# installs chaincart-env in editable mode with the sb3, test, plot, mujoco and rllib extras
# (`maturin develop --release --extras sb3,test,plot,mujoco,rllib`). Re-running it is cheap: the
# Python dependencies are reinstalled only when pyproject.toml changed, and the
# extension is rebuilt only when the Rust sources changed (cargo decides).
#
# Environment: PYTHON (default python3.11) picks the interpreter for a new .venv;
# CARGO_TARGET_DIR is honoured.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

PYTHON="${PYTHON:-$(command -v python3.11 || command -v python3)}"

# System packages of the window tests: a virtual X display, and Tk for the
# interpreter's tkinter (matplotlib's TkAgg window).
missing=()
command -v Xvfb >/dev/null 2>&1 || missing+=(xvfb)
"$PYTHON" -c "import tkinter" >/dev/null 2>&1 || missing+=(python3-tk)
if [ ${#missing[@]} -gt 0 ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        echo "setup: installing ${missing[*]} (apt-get)"
        apt-get update -q
        DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
    else
        echo "setup: ${missing[*]} missing (the human-mode window tests will fail): apt-get install ${missing[*]}" >&2
    fi
fi
if [ ! -x .venv/bin/python ]; then
    echo "setup: creating .venv with $PYTHON"
    "$PYTHON" -m venv .venv
fi
export VIRTUAL_ENV="$PWD/.venv"
export PATH="$VIRTUAL_ENV/bin:$PATH"

stamp=.venv/.chaincart-setup
want="$(sha256sum pyproject.toml | cut -d' ' -f1)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ] || ! python -c "import maturin" >/dev/null 2>&1; then
    python -m pip install --upgrade pip
    python -m pip install "maturin>=1.5,<2"
    maturin develop --release --extras sb3,test,plot,mujoco,rllib
    echo "$want" > "$stamp"
else
    # Dependencies are in place: rebuild the extension in place if Rust changed.
    maturin develop --release --skip-install --quiet
fi
python -c "import chaincart_env, chaincart_env._core; print('setup: chaincart_env', chaincart_env.__version__, 'ready')"
