"""Training-only reward shaping: a penalty on the step that leaves the track.

The swing-ups train on the sharp ``exp`` reward, which is almost zero anywhere far from
the target. Leaving the track ends the episode, but while the chain still hangs that
ends nothing worth having: an agent pumping energy into the chain loses nothing by
running off the end, and a seed that learns to pump hard before it learns to brake
never learns to stay. A penalty on the step that leaves the track (the reward of that
step minus ``penalty``) makes running off cost what holding the target would earn
over ``penalty`` steps. Evaluations keep the scene's reward and success, and the
training log (``training_episodes.csv``) records returns with the penalty in them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import VecEnvWrapper

from chaincart_env.errors import InvalidInputError
from chaincart_env.history import PicklableVecWrapper

__all__ = ["OffTrackPenalty", "check_off_track_penalty"]


def check_off_track_penalty(penalty: Any) -> float:
    """``penalty`` as a float, or an InvalidInputError naming it: a finite number >= 0."""
    if isinstance(penalty, bool) or not isinstance(penalty, (int, float)) or not math.isfinite(penalty) or penalty < 0:
        raise InvalidInputError(f"off-track penalty = {penalty!r}: expected a finite number >= 0")
    return float(penalty)


class OffTrackPenalty(PicklableVecWrapper, VecEnvWrapper):  # type: ignore[misc]
    """A stable-baselines3 ``VecEnv`` (whose infos say ``out_of_track``) with ``penalty``
    subtracted from the reward of each step that leaves the track."""

    def __init__(self, venv: Any, penalty: float) -> None:
        super().__init__(venv)
        self.penalty = check_off_track_penalty(penalty)

    def reset(self) -> Any:
        """The wrapped envs' reset."""
        return self.venv.reset()

    def step_wait(self) -> Any:
        """The wrapped envs' step, with the penalty on each step that left the track."""
        obs, rewards, dones, infos = self.venv.step_wait()
        for i in np.flatnonzero(dones):
            if infos[i].get("out_of_track", False):
                rewards[i] -= self.penalty
        return obs, rewards, dones, infos
