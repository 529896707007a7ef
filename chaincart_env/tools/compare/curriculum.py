"""Start states along the planner's swing-up: a training curriculum for learned agents.

A swing-up rewards an agent only once the chain is up, and from hanging starts PPO needs
millions of steps before its own motions get there often enough to learn to hold the
top. Starting part of the training episodes from states the planner's swing-up passes
through (reference state initialisation, as in DeepMimic, Peng et al. 2018; the reset
distributions of Kakade and Langford, 2002) shows the agent every phase of the motion
from the first rollout: episodes that start late in the plan teach it to catch and hold
the top, those that start early teach it to pump.

:class:`PlanStarts` says how: a fixed share of the training episodes, ``fraction``,
starts at a state drawn uniformly along the plan (the planner's control-limited iLQR
plan from the scene's start equilibrium to its target, on the nominal model: what
:class:`~chaincart_env.policies.TrajectoryPolicy` tracks); the others start as the scene
says (hanging, with its start noise). :class:`~chaincart_env.tools.compare.plan_start_envs.PlanStartEnvs` applies it to the native
envs: after an env's episode ends (the native batch resets it in the same step), the
env is moved to its drawn plan state and its first observation replaced
(:mod:`~chaincart_env.tools.compare.plan_start_envs`; this module imports no
stable-baselines3). The draws come from their own seeded generator, so a run with a
curriculum is as reproducible as one without, and the wrapper pickles with its generator
(checkpoints resume bit for bit).

Evaluations are untouched: they run the scene's own starts.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, Mapping, Optional

import numpy as np

from chaincart_env.errors import InvalidInputError

__all__ = [
    "CURRICULA", "CURRICULUM_FILE", "FROZEN_CLIP", "JUDGED_STARTS", "JUDGES", "SCENE_CURRICULA",
    "SCENE_TRAINING_REWARDS", "PlanStarts", "check_plan_scene", "plan_observations", "plan_states", "scene_curriculum",
    "scene_training_reward", "window_start",
]  # fmt: skip

#: A training run's record of its reverse curriculum's windows (``env_steps,window`` rows).
CURRICULUM_FILE = "curriculum.csv"
#: The curricula ``compare --curriculum`` offers.
CURRICULA = ("none", "plan", "reverse")
#: What a reverse curriculum counts as a passed plan-start episode (:class:`PlanStarts`).
JUDGES = ("success", "held")
#: Which plan-start episodes a reverse curriculum judges (:class:`PlanStarts`).
JUDGED_STARTS = ("window", "newest")
#: How many standard deviations frozen statistics let an observation reach (SB3's
#: ``VecNormalize`` clips at 10): the starts of the widened windows lie far outside the
#: balance's spread, and clipped they would all read alike.
FROZEN_CLIP = 100.0
#: Offset of the curriculum's generator seed from the run's seed (apart from the envs' seeds).
SEED_OFFSET = 300_000


@dataclass(frozen=True)
class PlanStarts:
    """A share ``fraction`` of the training episodes starts at a state drawn uniformly
    along the planner's plan (the rest as the scene says). With ``reverse``, a reverse
    curriculum (Florensa et al., 2017): the draw starts from the last ``window`` of the
    plan (a share of its steps, the part nearest the target), and whenever ``judged``
    episodes started on the plan since the last change and at least ``threshold`` of
    them passed, the window grows by ``window`` towards the plan's start. ``judge``
    says what passes: ``success`` (the scene's success, ``is_success``) or ``held``
    (the episode reached its time limit within the scene's ``fall_limit``, which must
    be set: the chain was caught and never fell). ``held`` serves exploring policies,
    whose noise keeps a held chain outside the tight success tolerances.
    ``judged_starts`` says which of them count: ``window`` (every start in the window)
    or ``newest`` (only starts in the band the last widening added; the whole first
    window before it). Judged on the whole window, a widening can pass on the old
    bands while the policy fails from the new one; judged on the newest band, the
    window grows only once the policy holds what the last widening asked.

    ``freeze_statistics`` (reverse curricula of agents whose recipe normalises
    observations): the normalisation statistics stop counting at the first widening and
    clip at :data:`FROZEN_CLIP` standard deviations. Until then every start lies near the
    target, so the statistics' spread is the balance's, small; counting the wider starts
    of the next windows lifts it many times over, which rescales what the policy sees
    near the target and undid the balance it learned on ``swingup-3``. Frozen, the balance's inputs stay as learned and the new starts read
    as large inputs, not clipped ones.

    ``spread_floor`` (plan starts of agents whose recipe normalises observations; 0 for
    none): from the first step, the spread the statistics divide each observation
    component by is at least ``spread_floor`` times that component's spread over the
    plan's states (:func:`plan_observations`). Near the target the vertical components of
    upright links barely move (a spread of 0.01 on ``swingup-3``), so the statistics of a
    balance magnify them a hundredfold, and the plan's whip reads as inputs of 50 to 300
    standard deviations: past the tenth of the plan nearest the target, clipped. The
    floor leaves the components a balance steers by (the links' horizontal directions, the
    spins) at their own spread and bounds the rest."""

    fraction: float = 0.5
    reverse: bool = False
    window: float = 0.1
    threshold: float = 0.5
    judged: int = 256
    judge: str = "success"
    freeze_statistics: bool = False
    judged_starts: str = "window"
    spread_floor: float = 0.0

    def __post_init__(self) -> None:
        for name in ("fraction", "window", "threshold"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                math.isfinite(value) and 0.0 < value <= 1.0
            ):
                raise InvalidInputError(f"plan-start {name} = {value!r}: expected a number in (0, 1]")
        for name in ("reverse", "freeze_statistics"):
            if not isinstance(getattr(self, name), bool):
                raise InvalidInputError(f"plan-start {name} = {getattr(self, name)!r}: expected true or false")
        if self.freeze_statistics and not self.reverse:
            raise InvalidInputError("plan-start freeze_statistics = True without reverse: expected a reverse "
                                    "curriculum, whose first widening is when the statistics freeze")
        if isinstance(self.spread_floor, bool) or not isinstance(self.spread_floor, (int, float)) or not (
            math.isfinite(self.spread_floor) and 0.0 <= self.spread_floor <= 1.0
        ):
            raise InvalidInputError(f"plan-start spread_floor = {self.spread_floor!r}: expected a number in [0, 1] "
                                    "(a share of each observation's spread along the plan; 0 for none)")
        if isinstance(self.judged, bool) or not isinstance(self.judged, int) or self.judged < 1:
            raise InvalidInputError(f"plan-start judged = {self.judged!r}: expected an integer >= 1 (episodes)")
        if self.judge not in JUDGES:
            raise InvalidInputError(f"plan-start judge = {self.judge!r}: expected one of {', '.join(JUDGES)}")
        if self.judged_starts not in JUDGED_STARTS:
            raise InvalidInputError(f"plan-start judged_starts = {self.judged_starts!r}: expected one of "
                                    f"{', '.join(JUDGED_STARTS)}")
        if self.judged_starts != "window" and not self.reverse:
            raise InvalidInputError(f"plan-start judged_starts = {self.judged_starts!r} without reverse: expected a "
                                    "reverse curriculum, whose widenings are what is judged")

    @property
    def name(self) -> str:
        """The curriculum's name on the command line."""
        return "reverse" if self.reverse else "plan"

    def first_window(self) -> float:
        """The share of the plan (from its end) drawn from at first."""
        return self.window if self.reverse else 1.0

    def record(self) -> dict[str, Any]:
        """The settings as ``run.json`` records them."""
        return {"kind": "plan", **asdict(self)}

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> "PlanStarts":
        """The settings :meth:`record` wrote."""
        if record.get("kind") != "plan":
            raise InvalidInputError(f"curriculum record {dict(record)!r}: expected kind 'plan'")
        return cls(**{key: value for key, value in record.items() if key != "kind"})


#: The scenes whose learned agents train with plan starts unless ``--curriculum none``:
#: the double swing-up, where half the episodes starting along the plan (with the exp
#: training reward) took PPO from hanging to 96 % success at 1.25M steps in one seed of
#: three, and with the plan bonus of :mod:`~chaincart_env.tools.compare.shaping` in every
#: seed (docs/main-job.md, "Training recipes"); the spatial double swing-up likewise.
SCENE_CURRICULA: dict[str, PlanStarts] = {"swingup-2": PlanStarts(0.5), "spatial-swingup-2": PlanStarts(0.5)}
#: The reward the learned agents of a scene train on, where it is not the scene's own
#: (``--training-reward`` overrides it): the double swing-up trains on the sharp ``exp``
#: reward, which pays almost nothing away from the top, where the bounded ``tolerance``
#: reward's gentle slope left PPO unable to learn the hold (the same runs).
SCENE_TRAINING_REWARDS: dict[str, str] = {"swingup-2": "exp", "spatial-swingup-2": "exp"}


def scene_curriculum(scene: Optional[str]) -> Optional[PlanStarts]:
    """The curriculum ``scene``'s agents train with by default, or ``None``."""
    return SCENE_CURRICULA.get(scene or "")


def scene_training_reward(scene: Optional[str]) -> Optional[str]:
    """The reward ``scene``'s agents train on when it is not the scene's, or ``None``."""
    return SCENE_TRAINING_REWARDS.get(scene or "")


def window_start(last: int, share: float) -> int:
    """The earliest step of a plan of steps ``0..last`` in its last ``share`` (counted from
    the plan's end, as a reverse curriculum's windows are)."""
    return max(0, min(last, int(math.floor((1.0 - share) * last + 1e-9))))


def plan_observations(config: Any, states: np.ndarray) -> np.ndarray:
    """What the scene's env observes at each of ``states`` (model layout, one per row),
    shape ``(len(states), obs_dim)``, without noise."""
    from chaincart_env.sb3 import ChainCartVecEnv

    probe = ChainCartVecEnv(1, config.replace(obs_noise=None), seed=0)
    probe.reset()
    observations = np.empty((len(states), config.obs_dim), dtype=np.float64)
    for row, state in enumerate(states):
        probe.env_method("set_state", state, indices=0)
        observations[row] = probe._batch.observations()[0]
    return observations


def check_plan_scene(config: Any) -> None:
    """Refuses, by name, a scene without one start and one target to plan between."""
    if config.goal_conditioned:
        raise InvalidInputError(f"plan starts on scene {config.scene!r}: its episodes draw their start and "
                                "target, so there is no single plan; expected a scene with one start and one target")


def plan_states(config: Any) -> np.ndarray:
    """The states (model layout) of the planner's plan from ``config``'s start
    equilibrium to its target on the nominal model, shape ``(K + 1, state_dim)``;
    a :class:`~chaincart_env.errors.PlanningError` if the planner misses the target."""
    from chaincart_env.policies import TrajectoryPolicy
    from chaincart_env.policies.settings import nearest_equilibrium
    from chaincart_env.sb3 import ChainCartVecEnv

    check_plan_scene(config)
    probe = ChainCartVecEnv(1, config, seed=0)
    probe.reset()
    policy = TrajectoryPolicy.from_env(probe)
    start = nearest_equilibrium(policy.settings.model, probe.get_attr("model_state", 0)[0])
    return np.array(policy.plan(start, policy.settings.target).states, dtype=np.float64)
