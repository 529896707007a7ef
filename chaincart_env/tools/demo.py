"""``python -m chaincart_env demo``: one episode of a scene, printed as a short table.

The placeholder for the main job until the RL-vs-LQR comparison lands: it runs the
LQR baseline (or a zero / random policy) on the default scene and reports the return,
the paper's errors and whether the episode counts as a success.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Optional

import gymnasium as gym
import numpy as np

from chaincart_env.config import DEFAULT_SCENE, ChainCartConfig
from chaincart_env.env import ChainCartEnv

__all__ = ["run_demo"]


def _policy(name: str, env: ChainCartEnv, seed: int) -> Callable[[np.ndarray], np.ndarray]:
    if name == "zero":
        return lambda obs: np.zeros(env.config.force_dim, dtype=np.float32)
    if name == "random":
        env.action_space.seed(seed)
        return lambda obs: env.action_space.sample()
    from chaincart_env.policies.lqr import LQRPolicy

    lqr = LQRPolicy.from_env(env)
    return lambda obs: lqr.predict(obs)[0]


def run_demo(
    scene: Optional[str] = None, policy: str = "lqr", seed: int = 0, max_steps: Optional[int] = None
) -> int:
    """Rolls out one seeded episode of ``scene`` with ``policy`` (``lqr``, ``zero`` or ``random``)
    and prints a summary; returns the exit status."""
    config = ChainCartConfig(scene=scene or DEFAULT_SCENE)
    env = gym.make("ChainCart-v0", config=config, max_episode_steps=config.max_episode_steps)
    base = env.unwrapped
    assert isinstance(base, ChainCartEnv)
    act = _policy(policy, base, seed)
    obs, _ = env.reset(seed=seed)
    print(f"scene {config.scene}: {config.n_links} link(s), {'planar' if config.planar else 'spatial'}, "
          f"target {config.target_signs}, start {config.start!r} +- {config.start_noise}, "
          f"dt {config.dt} s, max_force {config.max_force} N, policy {policy}, seed {seed}")
    print()
    print("|      t (s) |  cart x (m) |   e_q |   e_w | force (N) | reward |")
    print("|-----------:|------------:|------:|------:|----------:|-------:|")
    every = max(1, round(0.5 / config.dt))
    total, k = 0.0, 0
    info: dict[str, Any] = {}
    terminated = False
    limit = config.max_episode_steps if max_steps is None else max_steps
    while k < limit:
        action = act(obs)
        obs, reward, terminated, truncated, info = env.step(action)
        total += float(reward)
        k += 1
        if k % every == 0 or terminated or truncated:
            e_q, e_w = base.model.errors(base.model_state, config.target_signs)
            force = np.clip(np.asarray(action, dtype=np.float64), -1, 1) * config.max_force
            print(f"| {k * config.dt:10.2f} | {base.model_state[0]:11.4f} | {e_q:5.3f} | {e_w:5.3f} | "
                  f"{float(np.linalg.norm(force)):9.3f} | {float(reward):6.4f} |")
        if terminated or truncated:
            break
    print()
    print(f"steps {k}, return {total:.2f} (max {k}), "
          f"ended by {'termination' if terminated else 'time limit' if info else 'step limit'}, "
          f"success {info.get('is_success', False)}")
    env.close()
    return 0 if math.isfinite(total) else 1
