#!/usr/bin/env bash
# Set-up of a machine that has only Rust and Python 3.11 with pip (idempotent).
#
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
