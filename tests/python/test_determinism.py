"""Seeded runs are reproducible bit for bit whatever the core's thread count."""

from __future__ import annotations

import os
import subprocess
import sys

SCRIPT = r"""
import hashlib, sys
import numpy as np
from chaincart_env import ChainCartVectorEnv, _core

envs = ChainCartVectorEnv(300, n_links=3, planar=False, start_noise=0.3, max_episode_steps=20,
                          track_limit=0.5, autoreset_mode="same_step", obs_dtype="float64")
h = hashlib.sha256()
obs, _ = envs.reset(seed=123)
h.update(obs.tobytes())
rng = np.random.default_rng(0)
ended = 0
for _ in range(60):
    obs, rewards, terminated, truncated, info = envs.step(rng.uniform(-1, 1, (300, 2)).astype(np.float32))
    for a in (obs, rewards, terminated, truncated):
        h.update(a.tobytes())
    ended += int((terminated | truncated).sum())
print(_core.num_threads(), ended, h.hexdigest())
"""


def run(threads: int) -> list[str]:
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    out = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, check=True)
    return out.stdout.split()


def test_results_do_not_depend_on_the_thread_count() -> None:
    one = run(1)
    assert one[0] == "1" and int(one[1]) > 300  # the pool really had one thread; episodes ended
    for threads in (2, 3):
        other = run(threads)
        assert other[0] == str(threads)  # the setting took effect
        assert other[1:] == one[1:]
