#!/usr/bin/env bash
# The main job: train PPO (stable-baselines3) on the default scene and compare it with
# the LQR baseline (`python -m chaincart_env compare`), writing tables, pictures and the
# model into ./runs/compare. About 5 minutes on two cores. Extra arguments go to
# compare (e.g. --timesteps 100000, --out runs/other, --scene inverted-1, --algo sac).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

scripts/setup.sh
exec .venv/bin/python -m chaincart_env compare --out runs/compare "$@"
