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
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Optional

__all__ = ["FIRST_STAGE_DIR", "first_stage"]

#: The first stage's folder inside the training run's folder.
FIRST_STAGE_DIR = "nominal-stage"
#: Written into the first stage's folder once it finished.
_DONE = "stage-finished"


def first_stage(directory: Path, train: Callable[[Path], object], existing: Optional[Path] = None) -> Path:
    """The folder of the agent the second stage starts from: ``existing`` when it holds a
    finished agent (a ``model.zip``), else ``directory/nominal-stage`` after
    ``train(folder)`` trained it there (skipped when a previous run finished it)."""
    from chaincart_env.tools.compare.run_files import MODEL_FILE

    if existing is not None and (Path(existing) / MODEL_FILE).is_file():
        return Path(existing)
    folder = Path(directory) / FIRST_STAGE_DIR
    if not (folder / _DONE).is_file():
        folder.mkdir(parents=True, exist_ok=True)
        train(folder)
        (folder / _DONE).write_text("finished\n")
    return folder
