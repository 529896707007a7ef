"""The controllers that the study (``compare --policies``) and the leaderboard
(``leaderboard --policies``) compare, by name: one table saying what each name is, the
label it has in tables and pictures, and where its class lives.

* Learned: ``ppo``, ``sac``, ``td3`` (stable-baselines3's ``PPO``, ``SAC``, ``TD3``),
  trained on the scene with its packaged recipe; ``ppo-robust``, PPO trained on the
  scene's robust variant (:mod:`chaincart_env.robust_training`: parameters, noise and
  delay drawn per episode, with observation history) and evaluated on the scene;
  ``ppo-residual``, PPO learning a correction of a model-based controller (the
  planner's time-varying LQR, or the LQR where episodes start at their target;
  :mod:`chaincart_env.residual`) with its recipe and the options given: the scene's
  own imitation, plan starts, training reward, shaping and polish are the plain agent's.
* Model-based, designed on the scene's nominal model with their class's ``from_env``:
  ``lqr`` (:class:`~chaincart_env.LQRPolicy`), ``mpc``, ``trajectory`` and ``energy``
  (``MPCPolicy``, ``TrajectoryPolicy``, ``EnergyPolicy`` of ``chaincart_env.policies``);
  ``trajectory-soft``, the planner's controller with a link-direction weight of 2
  instead of 10 (:data:`SOFT_PLAN_WEIGHTS`): a gentler plan, tracked less stiffly,
  which holds more of a swing-up when the true masses and lengths differ from the model's.

A ``--policies`` name may also be a shipped agent, ``pretrained:<scene>/<name>``
(:mod:`chaincart_env.pretrained_agents`): learned, but not trained by the run; it acts
as shipped.

Classes are imported by name when a controller is built, so that listing or checking
names imports nothing heavy, and a class that this installation lacks is a clear error
naming it. How each controller is drawn is in :mod:`chaincart_env.tools.compare.styles`.
"""

from __future__ import annotations

import difflib
import importlib
import re
from dataclasses import dataclass
from typing import Any, Optional

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError
from chaincart_env.residual import RESIDUAL_VARIANT
from chaincart_env.robust_training import ROBUST_VARIANT

__all__ = [
    "CONTROLLERS",
    "LEARNED",
    "SOFT_PLAN_WEIGHTS",
    "MODEL_BASED",
    "Controller",
    "NotApplicable",
    "build_model_based",
    "controller_class",
    "controller_of_label",
    "is_learned",
    "label_of",
    "parse_controllers",
]


@dataclass(frozen=True)
class Controller:
    """One controller: its ``--policies`` name, its label in tables and legends, the
    class that implements it (``module``, ``attribute``) and whether it is learned; a
    learned one trains with the recipes of ``algorithm`` (its hyperparameter file) for
    the scene's ``variant`` (``None``: the scene itself). A planner's controller may
    plan with other cost weights than the planner's defaults (``plan_weights``, pairs
    of ``ChainCart.plan``'s ``weights``)."""

    name: str
    label: str
    module: str
    attribute: str
    learned: bool
    algorithm: str = ""
    variant: Optional[str] = None
    plan_weights: tuple[tuple[str, float], ...] = ()

    @property
    def plans(self) -> bool:
        """Whether it follows the planner's plans (the time-varying LQR or MPC)."""
        return self.attribute in ("TrajectoryPolicy", "MPCPolicy")

    @property
    def recipe_algorithm(self) -> str:
        """The algorithm whose hyperparameter file holds this controller's recipes."""
        return self.algorithm or self.name

    @property
    def fine_tunes(self) -> bool:
        """Whether it trains in two stages: its algorithm's nominal agent first, then that
        agent fine-tuned on the variant (``ppo-robust``)."""
        return self.variant == ROBUST_VARIANT

    @property
    def takes_scene_methods(self) -> bool:
        """Whether it trains with the scene's methods beside its recipe (imitation, plan
        starts, training reward, shaping, polish): all but a residual agent, whose base is
        a model-based controller already."""
        return self.variant != RESIDUAL_VARIANT


#: The planner's cost weights of ``trajectory-soft`` (the others are the planner's
#: defaults): on ``swingup-2`` this controller holds 0.71 of the leaderboard's mismatch
#: axis where the default weights hold 0.67, level on the other axes but the largest
#: start perturbation.
SOFT_PLAN_WEIGHTS: tuple[tuple[str, float], ...] = (("q", 2.0),)

#: Every controller, in the order the help lists them.
CONTROLLERS: dict[str, Controller] = {
    controller.name: controller
    for controller in (
        Controller("ppo", "PPO", "stable_baselines3", "PPO", learned=True),
        Controller("sac", "SAC", "stable_baselines3", "SAC", learned=True),
        Controller("td3", "TD3", "stable_baselines3", "TD3", learned=True),
        Controller("ppo-robust", "PPO robust", "stable_baselines3", "PPO", learned=True, algorithm="ppo",
                   variant=ROBUST_VARIANT),
        Controller("ppo-residual", "PPO residual", "stable_baselines3", "PPO", learned=True, algorithm="ppo",
                   variant=RESIDUAL_VARIANT),
        Controller("lqr", "LQR", "chaincart_env.policies.lqr", "LQRPolicy", learned=False),
        Controller("mpc", "MPC", "chaincart_env.policies", "MPCPolicy", learned=False),
        Controller("trajectory", "Trajectory", "chaincart_env.policies", "TrajectoryPolicy", learned=False),
        Controller("trajectory-soft", "Trajectory soft", "chaincart_env.policies", "TrajectoryPolicy", learned=False,
                   plan_weights=SOFT_PLAN_WEIGHTS),
        Controller("energy", "Energy", "chaincart_env.policies", "EnergyPolicy", learned=False),
    )
}
#: The learned controllers (stable-baselines3 algorithms).
LEARNED: tuple[str, ...] = tuple(name for name, c in CONTROLLERS.items() if c.learned)
#: The model-based controllers.
MODEL_BASED: tuple[str, ...] = tuple(name for name, c in CONTROLLERS.items() if not c.learned)


class NotApplicable(InvalidInputError):
    """The controller cannot serve this scene (the message says why): the energy
    controller on a chain of two links, the LQR on a scene without force, ..."""


def _closest(name: str) -> str:
    close = difflib.get_close_matches(name, list(CONTROLLERS), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def parse_controllers(text: str, option: str = "--policies") -> list[str]:
    """``"ppo,lqr"`` (any case) into checked names, in the given order: each known (a
    controller, or ``pretrained:<scene>/<name>`` of a shipped agent), none twice, at
    least one."""
    from chaincart_env.pretrained_agents import is_pretrained_slot, parse_pretrained_slot

    names = [name.strip().lower() for name in str(text).split(",") if name.strip()]
    expected = (f"expected distinct names among {', '.join(CONTROLLERS)} or pretrained:<scene>/<name>, separated by "
                "commas")
    if not names:
        raise InvalidInputError(f"{option} {text!r}: {expected}")
    for name in names:
        if is_pretrained_slot(name):
            parse_pretrained_slot(name, option)
        elif name not in CONTROLLERS:
            raise InvalidInputError(f"{option} {text!r}: unknown controller {name!r}{_closest(name)}: {expected}")
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise InvalidInputError(f"{option} {text!r}: {', '.join(repeated)} given twice: {expected}")
    return names


def controller_class(name: str) -> Any:
    """The class of controller ``name`` (imported now); an InvalidInputError when the
    name is unknown or this installation does not have the class."""
    if name not in CONTROLLERS:
        raise InvalidInputError(f"controller {name!r}{_closest(str(name))}: expected one of {list(CONTROLLERS)}")
    controller = CONTROLLERS[name]
    try:
        return getattr(importlib.import_module(controller.module), controller.attribute)
    except (ImportError, AttributeError) as error:
        raise InvalidInputError(
            f"controller {name!r} needs {controller.module}.{controller.attribute}, which cannot be imported here "
            f"({error})"
        ) from None


def build_model_based(name: str, config: ChainCartConfig, oracle: bool = False, **options: Any) -> Any:
    """Model-based controller ``name`` for ``config``'s scene, built by its class's
    ``from_env`` on the nominal model (``oracle=True``: on the true parameters of
    the batch it is evaluated on, where the class offers that) with ``options`` on top
    of its own; :class:`NotApplicable` when it cannot serve the scene."""
    from chaincart_env.env import ChainCartEnv

    if name not in MODEL_BASED:
        raise InvalidInputError(f"controller {name!r}: expected a model-based one among {list(MODEL_BASED)}")
    policy_class, controller = controller_class(name), CONTROLLERS[name]
    options = {**options, "oracle": True} if oracle else dict(options)
    if controller.plans:
        # In a study a missed plan is a failed episode, not an aborted run.
        options["on_failure"] = "track"
    if controller.plan_weights:
        options["weights"] = dict(controller.plan_weights)
    try:
        return policy_class.from_env(ChainCartEnv(config), **options)
    except (ValueError, NotImplementedError) as error:
        raise NotApplicable(f"{name} cannot serve scene {config.scene!r}: {error}") from None


def label_of(name: str) -> str:
    """The label of controller ``name`` in tables and legends (``"PPO"``, ``"MPC"``; a
    shipped agent's is its slot, ``pretrained:<scene>/<name>``)."""
    return name if name not in CONTROLLERS else CONTROLLERS[name].label


def is_learned(name: str) -> bool:
    """Whether ``name`` is a learned policy: a learned controller or a shipped agent."""
    from chaincart_env.pretrained_agents import is_pretrained_slot

    return name in LEARNED or is_pretrained_slot(name)


_SEED = re.compile(r" \(seed \d+\)$")
#: Words a table adds after a label: the best model of a training run, the oracle
#: design on the true parameters, the RLlib trainer.
VARIANTS = ("best", "oracle")


def controller_of_label(text: str) -> tuple[Optional[str], str]:
    """The controller and variant a table's policy name shows: ``"PPO best (seed 3)"``
    -> ``("ppo", "best")``, ``"LQR oracle"`` -> ``("lqr", "oracle")``, ``"PPO (RLlib)"``
    and ``"ppo"`` -> ``("ppo", "")``; ``(None, "")`` for a name of no controller."""
    base = _SEED.sub("", text).replace(" (RLlib)", "").strip()
    variant = ""
    for word in VARIANTS:
        if base.endswith(" " + word):
            base, variant = base[: -len(word) - 1].strip(), word
            break
    by_label = {c.label.lower(): c.name for c in CONTROLLERS.values()}
    name = by_label.get(base.lower(), base.lower() if base.lower() in CONTROLLERS else None)
    return (name, variant) if name is not None else (None, "")
