"""Helpers of the conformance tests (their fixtures are in conftest.py)."""

from __future__ import annotations

import os
import warnings

#: Small, quick configurations that still cover planar/spatial and both dtypes.
CONFIGS = {
    "default": {},
    "inverted-1-f64": dict(scene="inverted-1", obs_dtype="float64"),
    "spatial-3": dict(n_links=3, planar=False, start_noise=0.2, max_episode_steps=40),
    "paper-fig3-short": dict(scene="paper-fig3", max_episode_steps=30),
}

#: Warnings of Gymnasium's checkers that its own env tests accept as well
#: (unbounded observation components are Box(-inf, inf) by Gymnasium's convention).
ACCEPTED_CHECKER_WARNINGS = (
    "A Box observation space minimum value is -infinity. This is probably too low.",
    "A Box observation space maximum value is infinity. This is probably too high.",
)


def unexpected_warnings(caught: list[warnings.WarningMessage], also: tuple[str, ...] = ()) -> list[str]:
    """Messages of caught warnings other than the accepted ones (and ``also``)."""
    accepted = ACCEPTED_CHECKER_WARNINGS + also
    return [str(w.message) for w in caught if not any(a in str(w.message) for a in accepted)]


def clean_environ() -> dict[str, str]:
    """The environment for a child process, without this worktree on PYTHONPATH."""
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    return env
