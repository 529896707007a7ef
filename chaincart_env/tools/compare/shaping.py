"""Training-only shaping: a penalty on the step that leaves the track, a bonus for
following the planner's swing-up, a penalty on sudden changes of the force, and a tube
around the planner's path whose leaving ends the episode.

The swing-ups train on the sharp ``exp`` reward, which is almost zero anywhere far from
the target. Two consequences, and a term for each:

* Leaving the track ends the episode, but while the chain still hangs that ends nothing
  worth having: an agent pumping energy into the chain loses nothing by running off the
  end. The off-track penalty (the reward of the step that leaves the track minus
  ``off_track_penalty``) makes running off cost what holding the target would earn over
  that many steps.
* A hanging chain and one swung almost high enough earn the same nothing, so from
  hanging there is no slope to climb: plan starts teach an agent to finish a swing-up,
  not to begin one. The plan bonus pays on every step for being
  near the planner's swing-up, and more the further along it the state lies, so that the
  beginning of the swing-up pays too. It has no clock: any state on the path earns its
  progress, whenever it is reached.

The plan tube shapes where episodes end rather than the reward: an episode ends once
the chain lies farther than its radius from every state of the plan
(:mod:`~chaincart_env.tools.compare.plan_tube` says why).

Evaluations keep the scene's reward, success and episode ends, and the training log
(``training_episodes.csv``) records returns with the shaping in them. The settings live
here; the SB3 wrappers that apply them, in :mod:`~chaincart_env.tools.compare.shaped_rewards`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any, Mapping, Optional

from chaincart_env.errors import InvalidInputError

__all__ = [
    "LEFT_PLAN", "SCENE_SHAPING", "Shaping", "check_action_change_penalty", "check_off_track_penalty", "check_plan_bonus",
    "check_plan_tube", "check_scale", "scene_shaping",
]


#: The info key of a training episode the plan tube ended.
LEFT_PLAN = "left_plan"


def check_scale(value: Any, what: str) -> float:
    """The scale of a training-only term (a shaping term, a second loss's weight) as a
    float, or an InvalidInputError naming it as ``what``: a finite number >= 0."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
        raise InvalidInputError(f"{what} = {value!r}: expected a finite number >= 0")
    return float(value)


def check_off_track_penalty(penalty: Any) -> float:
    """``penalty`` as a float, or an InvalidInputError naming it: a finite number >= 0."""
    return check_scale(penalty, "off-track penalty")


def check_plan_bonus(scale: Any) -> float:
    """``scale`` as a float, or an InvalidInputError naming it: a finite number >= 0."""
    return check_scale(scale, "plan bonus")


def check_action_change_penalty(scale: Any) -> float:
    """``scale`` as a float, or an InvalidInputError naming it: a finite number >= 0."""
    return check_scale(scale, "action-change penalty")


def check_plan_tube(radius: Any) -> float:
    """``radius`` as a float, or an InvalidInputError naming it: a finite number >= 0
    (0: no tube)."""
    return check_scale(radius, "plan tube")


@dataclass(frozen=True)
class Shaping:
    """The training-only shaping of a learned agent's reward (0: none of that term):
    ``off_track_penalty`` on the step that leaves the track, ``plan_bonus``, the
    most a step earns for following the planner's swing-up
    (:class:`~chaincart_env.tools.compare.shaped_rewards.PlanProgress`), and
    ``action_change_penalty``, the cost of a squared change of the action
    (:class:`~chaincart_env.tools.compare.shaped_rewards.ActionChangePenalty`), and
    ``plan_tube``, the radius of the tube around the planner's path whose leaving ends
    an episode (:class:`~chaincart_env.tools.compare.plan_tube.PlanTube`). A record
    written before a term existed reads it as 0."""

    off_track_penalty: float = 0.0
    plan_bonus: float = 0.0
    action_change_penalty: float = 0.0
    plan_tube: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "off_track_penalty", check_off_track_penalty(self.off_track_penalty))
        object.__setattr__(self, "plan_bonus", check_plan_bonus(self.plan_bonus))
        object.__setattr__(self, "action_change_penalty", check_action_change_penalty(self.action_change_penalty))
        object.__setattr__(self, "plan_tube", check_plan_tube(self.plan_tube))

    @property
    def follows_plan(self) -> bool:
        """Whether a term needs the planner's plan (the plan bonus or the tube)."""
        return bool(self.plan_bonus or self.plan_tube)

    def __bool__(self) -> bool:
        return any(getattr(self, f.name) for f in fields(self))

    def given(self) -> list[str]:
        """The command-line options of the terms in use."""
        return [f"--{f.name.replace('_', '-')} {getattr(self, f.name)}" for f in fields(self) if getattr(self, f.name)]

    def record(self) -> dict[str, float]:
        """The settings as ``run.json`` records them."""
        return asdict(self)

    @classmethod
    def from_record(cls, record: Optional[Mapping[str, Any]]) -> "Shaping":
        """The settings :meth:`record` wrote (``None``: no shaping)."""
        return cls(**(record or {}))

    def with_overrides(self, **given: Optional[float]) -> "Shaping":
        """These settings with each term given (not ``None``) replaced."""
        return Shaping(**{**self.record(), **{k: v for k, v in given.items() if v is not None}})


#: The shaping the learned agents of a scene train with unless an option overrides it.
#: The double swing-up takes the plan bonus: with it PPO swung up from hanging for seeds
#: where plan starts and the ``exp`` reward alone never did (docs/main-job.md, "Training
#: recipes"). The off-track penalty is no scene's default: it kept a seed on the track
#: but did not make it learn the swing-up. The spatial double swing-up takes the same bonus.
SCENE_SHAPING: dict[str, Shaping] = {"swingup-2": Shaping(plan_bonus=0.3), "spatial-swingup-2": Shaping(plan_bonus=0.3)}


def scene_shaping(scene: Optional[str]) -> Shaping:
    """The scene's default shaping (none for most scenes)."""
    return SCENE_SHAPING.get(scene or "", Shaping())
