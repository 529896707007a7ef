"""Robust training: the conditions a robust agent trains under.

An agent trained on the nominal system alone meets the leaderboard's axes (model
mismatch, sensor noise, force noise, control delay) for the first time when it is
scored on them. A robust agent trains on a distribution that covers them instead,
each drawn afresh at every episode's reset: masses and lengths within +-30 %,
observation noise, a multiplicative force disturbance of 30 %, a control delay of 0 or
1 period and starts spread over +-0.3 (a recipe may add the last observations and
actions to what the agent sees, :mod:`chaincart_env.history`, with its zoo entry's
``env_wrapper``). ``compare`` and the leaderboard train it in two stages
(:mod:`chaincart_env.tools.compare.stages`): the nominal agent first, then fine-tuned on
these conditions.

Every scene has a robust variant with its own Gymnasium id,
``ChainCart-<scene>-robust-v0`` (the scene plus :data:`ROBUST_CONDITIONS`), which RL
Baselines3 Zoo trains on with the ``-robust`` entries of the packaged hyperparameter
files; ``compare --policies ppo-robust`` and ``leaderboard --policies ppo-robust`` train
on the same conditions and evaluate on the scene itself.
"""

from __future__ import annotations

from typing import Any, Mapping

from chaincart_env.config import ChainCartConfig

__all__ = ["ROBUST_CONDITIONS", "ROBUST_VARIANT", "robust_config"]

#: The name of the variant: in env ids (``ChainCart-swingup-2-robust-v0``) and in
#: controller names (``ppo-robust``).
ROBUST_VARIANT = "robust"

#: The configuration keys a robust agent trains with, on top of the scene's: what the
#: leaderboard's axes vary, drawn per episode within their middle ranges.
ROBUST_CONDITIONS: Mapping[str, Any] = {
    "randomize": {"cart_mass": 0.3, "link_masses": 0.3, "link_lengths": 0.3},
    "obs_noise": 0.01,
    "force_noise": {"multiplicative": 0.3},
    "action_delay": (0, 1),
    "start_noise": 0.3,
}


def robust_config(config: ChainCartConfig) -> ChainCartConfig:
    """``config`` with :data:`ROBUST_CONDITIONS` on top."""
    return config.replace(**ROBUST_CONDITIONS)
