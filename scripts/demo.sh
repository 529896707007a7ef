#!/usr/bin/env bash
# The main job: train PPO (stable-baselines3) on the default scene and compare it with
# the LQR baseline over start sizes and model mismatch (`python -m chaincart_env
# compare`), writing report.md, tables, pictures and the models into ./runs/compare.
# About a minute on two cores after set-up. Extra arguments go to compare (e.g.
# --seeds 0,1,2, --sweep delay=0,1,2, --out runs/other, --scene inverted-1, --algo sac).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

scripts/setup.sh sb3,plot  # the extras of compare; the test suite needs them all
exec .venv/bin/python -m chaincart_env compare --out runs/compare "$@"
