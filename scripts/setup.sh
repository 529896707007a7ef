#!/usr/bin/env bash
# Set-up for the README's commands on a machine with Rust (cargo) and Python 3.11 with
# pip. Idempotent, and cheap to re-run: dependencies are installed only when
# pyproject.toml, constraints.txt or the wanted extras changed, the extension is
# rebuilt only when the Rust sources changed (cargo decides). Every set-up installs the
# versions pinned in constraints.txt (scripts/lock.sh refreshes it), so the demo and
# the test suite run the same ones.
#
#   scripts/setup.sh [EXTRAS]
#
# EXTRAS (comma-separated, default: every one) are the package's optional dependencies
# to install: scripts/demo.sh asks for sb3,plot; scripts/test.sh for every extra.
#
# It creates .venv (with $PYTHON, default python3.11), installs uv and maturin into it,
# builds the Rust extension with the `setup` profile of Cargo.toml (optimised as
# release, with thin LTO and parallel codegen: faster to build than the fat-LTO release
# profile of published wheels) and installs chaincart-env in editable mode with EXTRAS
# (`maturin develop --profile setup --extras EXTRAS`). Run the package with
# .venv/bin/python (or `source .venv/bin/activate` first).
#
# The test suite (extra "test") also needs two system packages for its real-window
# tests: Xvfb (a virtual X display) and Tk (matplotlib's window). When they are missing
# and this runs as root on Debian, it installs them with apt-get; otherwise it says
# which are missing, and those tests fail.
#
# The wheel test of the suite builds with the same profile, interpreter and environment,
# so the two share one build (see the wheel test's fixture).
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

# The stamp holds the hash of pyproject.toml and constraints.txt, and the extras
# installed with them.
stamp=.venv/.chaincart-setup
pyproject="$(cat pyproject.toml constraints.txt | sha256sum | cut -d' ' -f1)"
installed=""
if [ -f "$stamp" ] && [ "$(head -n1 "$stamp")" = "$pyproject" ]; then
    installed="$(sed -n 2p "$stamp")"
fi
needed=""
for extra in ${extras//,/ }; do
    has_extra "$installed" "$extra" || needed="$needed,$extra"
done
# Set-up's own tools, pinned: uv installs the dependencies (in parallel, within
# constraints.txt), maturin builds the extension.
setup_tools=("uv==0.13.9" "maturin==1.16.0")
if [ ! -x .venv/bin/uv ] || [ ! -x .venv/bin/maturin ]; then
    # Into .venv even if the base interpreter has them (a --system-site-packages venv):
    # `python -m maturin` finds only a maturin script of its own environment.
    python -m pip install --quiet --disable-pip-version-check --ignore-installed "${setup_tools[@]}"
fi
if [ -n "$needed" ]; then
    union="${installed:+$installed,}${extras}"
    union="$(tr ',' '\n' <<<"$union" | sort -u | paste -sd, -)"
    echo "setup: installing the dependencies of the extras $union (versions of constraints.txt)"
    extra_args=()
    for extra in ${union//,/ }; do extra_args+=(--extra "$extra"); done
    uv pip install --quiet --python "$VIRTUAL_ENV/bin/python" --constraint constraints.txt \
        -r pyproject.toml "${extra_args[@]}"
    echo "setup: building chaincart-env and installing it in editable mode"
    maturin develop --profile setup --uv --extras "$union"
    printf '%s\n%s\n' "$pyproject" "$union" > "$stamp"
else
    # Dependencies are in place: rebuild the extension in place if Rust changed.
    maturin develop --profile setup --skip-install --quiet
fi
python -c "import chaincart_env, chaincart_env._core; print('setup: chaincart_env', chaincart_env.__version__, 'ready in .venv')"
