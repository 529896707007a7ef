#!/usr/bin/env bash
# The main job, in two parts:
# 1. train PPO (stable-baselines3) on the default scene and compare it with the LQR
#    baseline over start sizes and model mismatch (`python -m chaincart_env compare`):
#    report.md, tables, pictures and the models in runs/compare;
# 2. the large motion, without training: the shipped swing-up agents (nominal and
#    robust) against the planner's time-varying LQR (trajectory), MPC and the LQR on the
#    double swing-up, under control delays of 0-2 periods and sensor noise:
#    runs/compare/swingup-2/report.md, with a filmstrip of the swing-up.
# About two minutes on two cores after set-up. Extra arguments go to the first compare only
# (e.g. --seeds 0,1,2, --sweep delay=0,1,2, --out runs/other, --scene inverted-1, --algo sac).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

scripts/setup.sh sb3,plot  # the extras of compare; the test suite needs them all
.venv/bin/python -m chaincart_env compare --out runs/compare "$@"
.venv/bin/python -m chaincart_env compare --scene swingup-2 --no-progress \
    --policies pretrained:swingup-2/ppo,pretrained:swingup-2/ppo-robust,pretrained:swingup-2/ppo-residual,trajectory,mpc,lqr \
    --eval-episodes 10 \
    --sweep delay=0,1,2 --sweep obs_noise=0,0.01 \
    --out runs/compare/swingup-2
echo "reports: runs/compare/report.md (main job) and runs/compare/swingup-2/report.md (swing-up)"
