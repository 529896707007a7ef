"""Training in two stages: a learned controller that trains on a variant of the scene
(``ppo-robust``) first has its algorithm's nominal agent of the same seed (the scene's
recipe), then fine-tunes it on the variant from its weights.

Learning the swing-up under noise, delay and mismatch from scratch failed where the
nominal recipe succeeds; fine-tuning an agent that already swings the chain up, at a
tenth of its learning rate, kept the motion and made it hold under the draws
(docs/leaderboard.md). The first stage lives in the run's folder (``nominal-stage/``),
marked finished once it is, so that an interrupted run resumes whichever stage it was
in; where the study trains the nominal agent of that seed anyway, that agent is the
first stage.

A polish (``compare --polish STEPS``) is a second stage of the same algorithm on the
same scene: the run's agent, its best evaluated model, trained on for STEPS at a tenth
of its learning rate. PPO at its training rate finds the spatial swing-up and loses it
again between evaluations; at a tenth of it, from the best model, it holds it
(docs/main-job.md). The first stage then lives in ``main-stage/``.
"""

from __future__ import annotations

import inspect
import math
from pathlib import Path
from typing import Any, Callable, Mapping, Optional

from chaincart_env.errors import InvalidInputError

__all__ = [
    "FIRST_STAGE_DIR", "POLISH_FIRST_STAGE_DIR", "POLISH_RATE_FACTOR", "SCENE_POLISH", "chosen_polish", "first_stage",
    "polish_stage",
]  # fmt: skip

#: The first stage's folder inside the training run's folder.
FIRST_STAGE_DIR = "nominal-stage"
#: The first stage's folder of a polished run.
POLISH_FIRST_STAGE_DIR = "main-stage"
#: A polish's learning rate, as a share of the run's.
POLISH_RATE_FACTOR = 0.1
#: The scenes whose learned agents are polished unless ``--polish 0``, and for how many
#: steps: the double swing-ups, which PPO finds and then loses again between evaluations
#: (docs/main-job.md).
SCENE_POLISH: dict[str, int] = {"swingup-2": 1_000_000, "spatial-swingup-2": 1_500_000}
#: Written into the first stage's folder once it finished.
_DONE = "stage-finished"


def first_stage(
    directory: Path, train: Callable[[Path], object], existing: Optional[Path] = None, name: str = FIRST_STAGE_DIR
) -> Path:
    """The folder of the agent the second stage starts from: ``existing`` when it holds a
    finished agent (a ``model.zip``), else ``directory/name`` after ``train(folder)``
    trained it there (skipped when a previous run finished it)."""
    from chaincart_env.tools.compare.run_files import MODEL_FILE

    if existing is not None and (Path(existing) / MODEL_FILE).is_file():
        return Path(existing)
    folder = Path(directory) / name
    if not (folder / _DONE).is_file():
        folder.mkdir(parents=True, exist_ok=True)
        train(folder)
        (folder / _DONE).write_text("finished\n")
    return folder


def polish_stage(
    algo: str, main: Mapping[str, Any], steps: int, learning_rate: Optional[float] = None
) -> dict[str, Any]:
    """The training settings of a run polished for ``steps``: ``main`` (the settings of
    ``algo``'s run) as its first stage, then ``steps`` more from its best model at
    ``learning_rate`` (default: :data:`POLISH_RATE_FACTOR` times the run's constant rate,
    or the start of a zoo ``lin_`` schedule)
    with everything else kept, but the imitation, which the first stage did."""
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise InvalidInputError(f"polish = {steps!r}: expected a whole number of steps >= 1")
    if learning_rate is None:
        from chaincart_env.tools.compare.recipes import schedule_start

        rate = main["hyperparameters"].get("learning_rate", _default_learning_rate(algo))
        rate = schedule_start(rate) or rate  # the zoo's linear decay: its start
        if isinstance(rate, bool) or not isinstance(rate, (int, float)):
            raise InvalidInputError(f"polish of {algo} with learning_rate = {rate!r}: expected a constant rate or "
                                    "lin_<rate> to take a tenth of, or --polish-learning-rate")
        learning_rate = POLISH_RATE_FACTOR * float(rate)
    if isinstance(learning_rate, bool) or not isinstance(learning_rate, (int, float)) or not 0 < learning_rate < math.inf:
        raise InvalidInputError(f"polish learning rate = {learning_rate!r}: expected a finite number > 0")
    first = {**main, "algo": algo, "folder": POLISH_FIRST_STAGE_DIR}
    return {
        **main,
        "timesteps": steps,
        "hyperparameters": {**main["hyperparameters"], "learning_rate": float(learning_rate)},
        "imitation": None,
        "polish": {"timesteps": steps, "learning_rate": float(learning_rate)},
        "first_stage": first,
    }


def _default_learning_rate(algo: str) -> Any:
    """The learning rate SB3 gives ``algo`` when none is set."""
    from chaincart_env.tools.compare.algorithms import algorithm_class

    return inspect.signature(algorithm_class(algo)).parameters["learning_rate"].default


def chosen_polish(scene: Optional[str], polish: Any, timesteps: Optional[int] = None) -> Optional[dict[str, Any]]:
    """The polish a run takes: ``"scene"``, the scene's (:data:`SCENE_POLISH`, else
    none), which comes with the recipe's budget only (none where ``timesteps`` gives
    the run one of its own); ``None`` or ``{"timesteps": 0}``: none; else ``polish``
    itself."""
    if isinstance(polish, str) and polish == "scene":
        steps = SCENE_POLISH.get(scene or "") if timesteps is None else None
        return None if steps is None else {"timesteps": steps}
    if polish is None or polish.get("timesteps") == 0:
        return None
    return dict(polish)
