#!/usr/bin/env bash
# The main job. Until the RL-vs-LQR comparison lands: a short demo rollout of the
# default scene (`python -m chaincart_env demo`). Extra arguments go to the demo
# (e.g. --scene paper-fig2 --policy zero).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

scripts/setup.sh
exec .venv/bin/python -m chaincart_env demo "$@"
