#!/usr/bin/env bash
# Set-up for the README's commands on a machine with Rust (cargo) and Python 3.11 with
# pip. Idempotent, and cheap to re-run: dependencies are installed only when
# pyproject.toml or the wanted extras changed, the extension is rebuilt only when the
# Rust sources changed (cargo decides).
#
#   scripts/setup.sh [EXTRAS]
#
# EXTRAS (comma-separated, default: every one) are the package's optional dependencies
# to install: scripts/demo.sh asks for sb3,plot; scripts/test.sh for every extra.
#
# It creates .venv (with $PYTHON, default python3.11), installs maturin into it, builds
# the Rust extension in release mode and installs chaincart-env in editable mode with
# EXTRAS (`maturin develop --release --extras EXTRAS`). Run the package with
# .venv/bin/python (or `source .venv/bin/activate` first).
#
# The test suite (extra "test") also needs two system packages for its real-window
# tests: Xvfb (a virtual X display) and Tk (matplotlib's window). When they are missing
# and this runs as root on Debian, it installs them with apt-get; otherwise it says
# which are missing, and those tests fail.
#
# The wheel test of the suite builds with the same interpreter and environment, so the
# two share one release build (see the wheel test's fixture).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

ALL_EXTRAS=sb3,plot,test,mujoco,rllib
extras="${1:-$ALL_EXTRAS}"
PYTHON="${PYTHON:-$(command -v python3.11 || command -v python3)}"

has_extra() { [[ ",$1," == *",$2,"* ]]; }

if has_extra "$extras" test; then
    missing=()
    command -v Xvfb >/dev/null 2>&1 || missing+=(xvfb)
    "$PYTHON" -c "import tkinter" >/dev/null 2>&1 || missing+=(python3-tk)
    if [ ${#missing[@]} -gt 0 ]; then
        if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
            echo "setup: installing ${missing[*]} with apt-get (system packages of the real-window tests)"
            apt-get update -q
            DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
        else
            echo "setup: ${missing[*]} missing: the real-window tests will fail; as root: apt-get install ${missing[*]}" >&2
        fi
    fi
fi

if [ ! -x .venv/bin/python ]; then
    echo "setup: creating .venv with $PYTHON"
    "$PYTHON" -m venv .venv
fi
export VIRTUAL_ENV="$PWD/.venv"
export PATH="$VIRTUAL_ENV/bin:$PATH"

# The stamp holds the hash of pyproject.toml and the extras installed with it.
stamp=.venv/.chaincart-setup
pyproject="$(sha256sum pyproject.toml | cut -d' ' -f1)"
installed=""
if [ -f "$stamp" ] && [ "$(head -n1 "$stamp")" = "$pyproject" ]; then
    installed="$(sed -n 2p "$stamp")"
fi
needed=""
for extra in ${extras//,/ }; do
    has_extra "$installed" "$extra" || needed="$needed,$extra"
done
if [ ! -x .venv/bin/maturin ]; then
    # Into .venv even if the base interpreter has it (a --system-site-packages venv):
    # `python -m maturin` finds only a maturin script of its own environment.
    python -m pip install --quiet --upgrade pip
    python -m pip install --quiet --ignore-installed "maturin>=1.5,<2"
fi
if [ -n "$needed" ]; then
    union="${installed:+$installed,}${extras}"
    union="$(tr ',' '\n' <<<"$union" | sort -u | paste -sd, -)"
    echo "setup: installing chaincart-env with the extras $union"
    maturin develop --release --extras "$union"
    printf '%s\n%s\n' "$pyproject" "$union" > "$stamp"
else
    # Dependencies are in place: rebuild the extension in place if Rust changed.
    maturin develop --release --skip-install --quiet
fi
python -c "import chaincart_env, chaincart_env._core; print('setup: chaincart_env', chaincart_env.__version__, 'ready in .venv')"
