"""``python -m chaincart_env evaluate pretrained:<scene>/<name>``: a shipped agent's
comparison on the scene it was trained on, against the paper's LQR where the LQR can
serve that scene, on the seeded starts its record was measured on unless told
otherwise (so the success rate it reports is the record's, measured again)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Optional

from chaincart_env.pretrained_agents import parse_pretrained_slot, pretrained

__all__ = ["DEFAULT_OUT", "evaluate_pretrained"]

#: Where ``evaluate pretrained:<scene>/<name>`` writes unless ``--out`` says: ``<this>/<scene>-<name>``.
DEFAULT_OUT = Path("runs/evaluate")


def evaluate_pretrained(
    slot: "str | Path",
    *,
    out: Optional[Path] = None,
    eval_episodes: Optional[int] = None,
    eval_seed: Optional[int] = None,
    torch_threads: Optional[int] = None,
    address: Optional[str] = None,
) -> list[dict[str, Any]]:
    """Evaluates the shipped agent ``slot`` (``pretrained:<scene>/<name>``) and the LQR
    (where it can serve the scene) on the agent's own scene, from ``eval_episodes``
    seeded starts from ``eval_seed`` (default: the record's measured starts), and writes
    the study's tables and pictures into ``out`` (default
    ``runs/evaluate/<scene>-<name>``); returns the summaries."""
    from chaincart_env.tools.compare.study import EVALUATION_FILES, describe, evaluate_study_at
    from chaincart_env.tools.controllers import NotApplicable, build_model_based

    scene, name = parse_pretrained_slot(str(slot), "evaluate")
    agent = pretrained(scene, name)
    config = agent.config()
    measured = agent.success
    episodes = int(measured.get("episodes", 50)) if eval_episodes is None else eval_episodes
    first = int(measured.get("first_seed", 0)) if eval_seed is None else eval_seed
    into = DEFAULT_OUT / f"{scene}-{name}" if out is None else Path(out)
    controllers = [agent.label]
    try:
        build_model_based("lqr", config)
        controllers.append("lqr")
    except NotApplicable as reason:
        print(f"{reason}: {agent.label} is evaluated alone")
    print(describe(config))
    print(f"evaluating {agent.label} (recorded success {measured.get('successes')}/{measured.get('episodes')} on seeds "
          f"{measured.get('first_seed')}..) -> {into}")
    options: dict[str, Any] = dict(runs=[], model_based=controllers, eval_seed=first, eval_episodes=episodes, sweeps={},
                                   into=into)
    evaluation = evaluate_study_at(address, into, config, torch_threads=torch_threads, **options)
    print(f"wrote {', '.join(EVALUATION_FILES)} in {into}")
    return evaluation.summaries
